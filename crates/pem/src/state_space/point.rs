//! The parameter vector θ of the model (A, B, C, D, K, x₀), its layout, and the predictor that gives the scaled residuals.

use nalgebra::{DMatrix, DVector};

use lifted_linalg::spectral_radius;
use lifted_subspace::Record;

/// The parameter vector θ and its layout.
#[derive(Debug, Clone)]
pub(super) struct Layout {
    pub(super) n: usize,
    pub(super) nu: usize,
    pub(super) ny: usize,
    pub(super) records: usize,
    pub(super) gain: bool,
    /// Free D entries (output, input).
    pub(super) d_free: Vec<(usize, usize)>,
}

impl Layout {
    pub(super) fn len(&self) -> usize {
        let (n, nu, ny) = (self.n, self.nu, self.ny);
        n * n
            + n * nu
            + ny * n
            + self.d_free.len()
            + if self.gain { n * ny } else { 0 }
            + self.records * n
    }

    /// Length of the model's part of θ (A, B, C, free D, K), before the
    /// initial states.
    pub(super) fn model_len(&self) -> usize {
        self.len() - self.records * self.n
    }
}

/// The step test of the iterations: `delta` (in θ's coordinates) is below
/// `tol` (1 + ‖θ_b‖) in every block b of θ — the model's parameters and
/// each record's initial state — not in one norm over all. An initial
/// state the records hardly determine (a fast mode whose free response is
/// over before the first measured sample of a multirate record) can be
/// 1e7 where the model's entries are of order 1, and one norm over both
/// stopped the iterations after two steps as converged (issue 26, the
/// multirate record starting between slow samples: cost 1.5e-2 where
/// 1.0e-2 is reached).
pub(super) fn step_is_small(
    delta: &DVector<f64>,
    theta: &DVector<f64>,
    lay: &Layout,
    tol: f64,
) -> bool {
    let model = lay.model_len();
    let blocks = std::iter::once((0, model))
        .chain((0..lay.records).map(|r| (model + r * lay.n, lay.n)))
        .filter(|&(_, len)| len > 0);
    for (at, len) in blocks {
        let step = delta.rows(at, len).norm();
        if step > tol * (1.0 + theta.rows(at, len).norm()) {
            return false;
        }
    }
    true
}

/// Model matrices and initial states as one value.
#[derive(Debug, Clone)]
pub(super) struct Point {
    pub(super) a: DMatrix<f64>,
    pub(super) b: DMatrix<f64>,
    pub(super) c: DMatrix<f64>,
    pub(super) d: DMatrix<f64>,
    pub(super) k: DMatrix<f64>,
    pub(super) x0: Vec<DVector<f64>>,
}

impl Point {
    pub(super) fn pack(&self, lay: &Layout) -> DVector<f64> {
        let mut v = Vec::with_capacity(lay.len());
        v.extend(self.a.iter());
        v.extend(self.b.iter());
        v.extend(self.c.iter());
        v.extend(lay.d_free.iter().map(|&(o, j)| self.d[(o, j)]));
        if lay.gain {
            v.extend(self.k.iter());
        }
        for x in &self.x0 {
            v.extend(x.iter());
        }
        DVector::from_vec(v)
    }

    pub(super) fn unpack(theta: &DVector<f64>, lay: &Layout) -> Point {
        let (n, nu, ny) = (lay.n, lay.nu, lay.ny);
        let mut at = 0;
        let mut take = |rows: usize, cols: usize| {
            let m = DMatrix::from_column_slice(rows, cols, &theta.as_slice()[at..at + rows * cols]);
            at += rows * cols;
            m
        };
        let a = take(n, n);
        let b = take(n, nu);
        let c = take(ny, n);
        let dv = take(lay.d_free.len(), 1);
        let mut d = DMatrix::zeros(ny, nu);
        for (i, &(o, j)) in lay.d_free.iter().enumerate() {
            d[(o, j)] = dv[(i, 0)];
        }
        let k = if lay.gain {
            take(n, ny)
        } else {
            DMatrix::zeros(n, ny)
        };
        let x0 = (0..lay.records)
            .map(|_| take(n, 1).column(0).into_owned())
            .collect();
        Point { a, b, c, d, k, x0 }
    }

    /// Tangent directions of the similarity x → (I + T)x at this point, one
    /// column per elementary T = e_i e_jᵀ (D and nothing else fixed).
    pub(super) fn similarity_tangent(&self, lay: &Layout) -> DMatrix<f64> {
        let n = lay.n;
        let mut q = DMatrix::zeros(lay.len(), n * n);
        for i in 0..n {
            for j in 0..n {
                let mut t = DMatrix::zeros(n, n);
                t[(i, j)] = 1.0;
                let dir = Point {
                    a: &t * &self.a - &self.a * &t,
                    b: &t * &self.b,
                    c: -(&self.c * &t),
                    d: DMatrix::zeros(lay.ny, lay.nu),
                    k: &t * &self.k,
                    x0: self.x0.iter().map(|x| &t * x).collect(),
                };
                q.column_mut(j * n + i).copy_from(&dir.pack(lay));
            }
        }
        q
    }
}

/// Scaled residuals of all records (measured samples only); `None` when
/// the predictor or simulation is unstable or overflows.
pub(super) fn residuals(
    p: &Point,
    records: &[Record<'_>],
    weights: &[f64],
    gain: bool,
    total: usize,
) -> Option<DVector<f64>> {
    lifted_linalg::simd::dispatch(
        #[inline(always)]
        || {
            let mut out = Vec::with_capacity(total);
            let (n, nu, ny) = (p.a.nrows(), p.b.ncols(), p.c.nrows());
            let mut z = vec![0.0; n + nu + ny];
            let mut next = vec![0.0; n];
            let mut meas = vec![false; ny];
            for (r, rec) in records.iter().enumerate() {
                let mut x = p.x0[r].as_slice().to_vec();
                for t in 0..rec.u.nrows() {
                    predictor_step(p, gain, rec, t, &mut x, &mut z, &mut meas, &mut next);
                    for o in 0..ny {
                        if meas[o] {
                            out.push(z[n + nu + o] * weights[o]);
                        }
                    }
                }
            }
            let v = DVector::from_vec(out);
            v.iter().all(|e| e.is_finite()).then_some(v)
        },
    )
}

/// One step of the predictor (simulation when `gain` is false) at time
/// `t`: fills z = [x̂; u; e_m] (e_m the residuals of the measured outputs,
/// 0 for the others), `meas` (which outputs are measured) and advances x̂,
/// using `next` as workspace. O(n (n + n_u + n_y)), no allocation.
#[allow(clippy::too_many_arguments)]
#[inline]
pub(super) fn predictor_step(
    p: &Point,
    gain: bool,
    rec: &Record<'_>,
    t: usize,
    x: &mut [f64],
    z: &mut [f64],
    meas: &mut [bool],
    next: &mut [f64],
) {
    let (n, nu, ny) = (p.a.nrows(), p.b.ncols(), p.c.nrows());
    let (a, b, c, d, k) = (
        p.a.as_slice(),
        p.b.as_slice(),
        p.c.as_slice(),
        p.d.as_slice(),
        p.k.as_slice(),
    );
    z[..n].copy_from_slice(x);
    for j in 0..nu {
        z[n + j] = rec.u[(t, j)];
    }
    for o in 0..ny {
        let yo = rec.y[(t, o)];
        meas[o] = !yo.is_nan();
        z[n + nu + o] = if meas[o] {
            let mut yhat = 0.0;
            for i in 0..n {
                yhat += c[o + i * ny] * x[i];
            }
            for j in 0..nu {
                yhat += d[o + j * ny] * z[n + j];
            }
            yo - yhat
        } else {
            0.0
        };
    }
    next.fill(0.0);
    for i in 0..n {
        let xi = x[i];
        for (nr, ar) in next.iter_mut().zip(&a[i * n..(i + 1) * n]) {
            *nr += ar * xi;
        }
    }
    for j in 0..nu {
        let uj = z[n + j];
        for (nr, br) in next.iter_mut().zip(&b[j * n..(j + 1) * n]) {
            *nr += br * uj;
        }
    }
    if gain {
        for o in 0..ny {
            let eo = z[n + nu + o];
            if eo != 0.0 {
                for (nr, kr) in next.iter_mut().zip(&k[o * n..(o + 1) * n]) {
                    *nr += kr * eo;
                }
            }
        }
    }
    x.copy_from_slice(next);
}

/// Mean of the squared entries.
pub(super) fn mean_square(e: &DVector<f64>) -> f64 {
    e.norm_squared() / e.len().max(1) as f64
}

/// Is the iterate admissible: a stable or marginal simulation (ρ(A) <
/// 1 + `marginal`, [`super::PemOptions::marginal_tolerance`]: an integrator
/// estimated just outside the unit circle stays where the data put it) and,
/// for the prediction cost, a stable predictor (ρ(A − KC) < 1, strictly:
/// the prediction error is defined only for a stable predictor)? With
/// `marginal` = 0 a refinement never turns a stable model unstable.
pub(super) fn admissible(p: &Point, gain: bool, marginal: f64) -> bool {
    let stable_a = spectral_radius(&p.a).is_ok_and(|r| r < 1.0 + marginal);
    if !gain {
        return stable_a;
    }
    stable_a && spectral_radius(&(&p.a - &p.k * &p.c)).is_ok_and(|r| r < 1.0)
}

/// Largest modulus of an eigenvalue of an unstable start moved inside the
/// unit circle ([`lifted_linalg::reflect_into_unit_disc`]).
pub(super) const STABILIZED_START_RADIUS: f64 = 0.999;

/// 1/std of each output's measured samples over the records (1 for a
/// constant output).
pub(super) fn output_weights(records: &[Record<'_>], ny: usize) -> Vec<f64> {
    (0..ny)
        .map(|o| {
            // Column o of each record (column-major storage).
            let column = |r: &Record<'_>| {
                let n = r.y.nrows();
                r.y.as_slice()[o * n..(o + 1) * n].to_vec()
            };
            let vals: Vec<f64> = records.iter().flat_map(column).collect();
            1.0 / lifted_lti::data::channel_scale(&vals)
        })
        .collect()
}

/// ‖A‖_F above this times √n marks a drifted realization of a stable
/// model (a Schur-stable A whose entries are that large is far from normal:
/// its coordinates, not its dynamics, have grown), which
/// [`Point::balanced`] brings back.
pub(super) const DRIFTED_NORM: f64 = 10.0;

impl Point {
    /// Whether the realization of a stable point has drifted (‖A‖_F >
    /// [`DRIFTED_NORM`] √n): the local coordinates of the iterations follow
    /// the data, not the conditioning, and on short records a refinement
    /// can end in a realization with entries of 1e4 whose simulation then
    /// loses digits (and whose x₀ regression fails its growth check).
    pub(super) fn drifted(&self) -> bool {
        let n = self.a.nrows();
        n > 0 && self.a.norm() > DRIFTED_NORM * (n as f64).sqrt()
    }

    /// The same model in its balanced realization (Moore 1981): the
    /// controllability Gramian of (A, [B K]) and the observability Gramian
    /// of (A, C) equal and diagonal, so the input–output and prediction
    /// behaviour is unchanged (B, K, x₀ → T⁻¹ ·, C → C T). `None` when A is
    /// not stable or the realization is not minimal to working precision
    /// (a Hankel singular value below 1e-12 of the largest). The transform
    /// is `lifted_lti::StateSpace::balancing` of (A, [B K], C). O(n³).
    pub(super) fn balanced(&self) -> Option<Point> {
        let n = self.a.nrows();
        if n == 0 || !spectral_radius(&self.a).is_ok_and(|r| r < 1.0) {
            return None;
        }
        let inputs = self.b.ncols() + self.k.ncols();
        let mut bk = DMatrix::zeros(n, inputs);
        bk.columns_mut(0, self.b.ncols()).copy_from(&self.b);
        bk.columns_mut(self.b.ncols(), self.k.ncols())
            .copy_from(&self.k);
        let pair = lifted_lti::StateSpace::new(
            self.a.clone(),
            bk,
            self.c.clone(),
            DMatrix::zeros(self.c.nrows(), inputs),
            Some(1.0),
        )
        .ok()?;
        let lifted_lti::Balancing {
            left: tl,
            right: tr,
            hsv,
        } = pair.balancing().ok()?;
        let largest = hsv.iter().copied().fold(0.0, f64::max);
        if tr.ncols() < n || hsv.iter().any(|&s| s.is_nan() || s <= 1e-12 * largest) {
            return None;
        }
        let out = Point {
            a: &tl * &self.a * &tr,
            b: &tl * &self.b,
            c: &self.c * &tr,
            d: self.d.clone(),
            k: &tl * &self.k,
            x0: self.x0.iter().map(|x| &tl * x).collect(),
        };
        let finite = out
            .a
            .iter()
            .chain(out.b.iter())
            .chain(out.c.iter())
            .all(|v| v.is_finite());
        finite.then_some(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// (C Aᵏ B, C Aᵏ K, C Aᵏ x₀) for k < 20: what a similarity leaves
    /// unchanged.
    fn markov(p: &Point) -> Vec<f64> {
        let mut out = Vec::new();
        let mut ak = DMatrix::identity(p.a.nrows(), p.a.nrows());
        for _ in 0..20 {
            let cak = &p.c * &ak;
            out.extend((&cak * &p.b).iter());
            out.extend((&cak * &p.k).iter());
            out.extend((&cak * &p.x0[0]).iter());
            ak = &ak * &p.a;
        }
        out
    }

    #[test]
    fn a_drifted_realization_is_balanced_to_the_same_model() {
        let good = Point {
            a: DMatrix::from_row_slice(2, 2, &[0.9, 0.2, -0.2, 0.9]),
            b: DMatrix::from_row_slice(2, 1, &[1.0, 0.5]),
            c: DMatrix::from_row_slice(1, 2, &[0.3, 0.4]),
            d: DMatrix::zeros(1, 1),
            k: DMatrix::from_row_slice(2, 1, &[0.1, -0.2]),
            x0: vec![DVector::from_row_slice(&[1.0, -1.0])],
        };
        assert!(!good.drifted());
        // Coordinates x = T z with T of condition ≈ 1e8.
        let t = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0 + 1e-4]);
        let ti = t.clone().try_inverse().unwrap();
        let drifted = Point {
            a: &ti * &good.a * &t,
            b: &ti * &good.b,
            c: &good.c * &t,
            d: good.d.clone(),
            k: &ti * &good.k,
            x0: vec![&ti * &good.x0[0]],
        };
        assert!(drifted.drifted(), "{}", drifted.a);
        let bal = drifted.balanced().unwrap();
        assert!(!bal.drifted(), "{}", bal.a);
        for (x, y) in markov(&good).iter().zip(markov(&bal)) {
            assert!((x - y).abs() < 1e-6 * (1.0 + x.abs()), "{x} vs {y}");
        }
        // Not for an unstable A.
        let unstable = Point {
            a: DMatrix::from_row_slice(2, 2, &[1.1, 0.0, 0.0, 0.5]),
            ..good
        };
        assert!(unstable.balanced().is_none());
    }

    #[test]
    fn a_large_initial_state_does_not_make_a_step_small() {
        // n = 2, one input, one output, K and D free, one record: the
        // model's 11 entries of order 1, x₀ of order 1e7.
        let lay = Layout {
            n: 2,
            nu: 1,
            ny: 1,
            records: 1,
            gain: true,
            d_free: vec![(0, 0)],
        };
        assert_eq!(lay.model_len(), 11);
        let mut theta = DVector::from_element(lay.len(), 0.5);
        theta[11] = 1.2e7;
        theta[12] = -3.0e6;
        // A step of 1e-6 in the model's entries: not small against them
        // (the one norm over θ, ≈ 1.2e7, called it small at 1e-10).
        let mut delta = DVector::zeros(lay.len());
        delta[0] = 1e-6;
        assert!(delta.norm() <= 1e-10 * (1.0 + theta.norm()));
        assert!(!step_is_small(&delta, &theta, &lay, 1e-10));
        // Small in every block: small.
        delta[0] = 1e-12;
        delta[11] = 1e-4;
        assert!(step_is_small(&delta, &theta, &lay, 1e-10));
        // A large step in x₀ alone is not small either.
        delta[11] = 1e-1;
        assert!(!step_is_small(&delta, &theta, &lay, 1e-10));
    }
}

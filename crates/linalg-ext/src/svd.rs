//! Thin singular value decomposition through faer.
//!
//! A = U diag(s) Vᵀ with U (m×k), V (n×k), k = min(m, n), s descending.
//! faer's bidiagonalisation + divide and conquer costs O(mn·min(m,n))
//! (≈ 4mn² + 8n³ for m ≥ n with vectors); [`singular_values`] skips the
//! vectors. [`svd_left`] of a wide matrix takes faer's own route (R of the
//! transpose, then the SVD of R) with the R of its own unblocked
//! reflections (faer's signs; 2nm² flops over contiguous columns).
//! The signs of paired singular vectors are arbitrary and vectors
//! of repeated singular values are determined only up to rotation
//! (Pitfall 1): compare subspaces or products, not raw columns.

use faer::diag::Diag;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::svd::{ComputeSvdVectors, svd_scratch};
use faer::{Mat, Par};
use nalgebra::{DMatrix, DVector};

use crate::check::check_finite;
use crate::convert::{as_faer, to_dmatrix};
use crate::{Error, Result};

/// Below this many flops (m·n·min(m, n)) a decomposition runs on the
/// calling thread: waking the thread pool costs more than it saves (on 2
/// cores, a 160×160 SVD took 3× longer in parallel than sequentially).
const SEQUENTIAL_FLOPS: f64 = 3.0e7;

/// The parallelism for an m×n decomposition: sequential when small, else
/// faer's global setting.
pub(crate) fn par_for(m: usize, n: usize) -> Par {
    let work = m as f64 * n as f64 * m.min(n) as f64;
    if work < SEQUENTIAL_FLOPS {
        Par::Seq
    } else {
        faer::get_global_parallelism()
    }
}

/// Singular values and, when asked for, the thin U and V (V empty when
/// only U was asked for).
type SvdParts = (Vec<f64>, Option<(Mat<f64>, Mat<f64>)>);

/// Which singular vectors [`faer_svd`] computes.
#[derive(Clone, Copy, PartialEq)]
enum Vectors {
    None,
    Left,
    Both,
}

/// faer's SVD with explicit parallelism.
fn faer_svd(a: &DMatrix<f64>, vectors: Vectors) -> Result<SvdParts> {
    let (m, n) = a.shape();
    let k = m.min(n);
    let par = par_for(m, n);
    let pick = |on: bool| {
        if on {
            ComputeSvdVectors::Thin
        } else {
            ComputeSvdVectors::No
        }
    };
    let (want_u, want_v) = (vectors != Vectors::None, vectors == Vectors::Both);
    let params = Default::default();
    let mut mem = MemBuffer::new(svd_scratch::<f64>(
        m,
        n,
        pick(want_u),
        pick(want_v),
        par,
        params,
    ));
    let mut s = Diag::<f64>::zeros(k);
    let mut u = Mat::<f64>::zeros(if want_u { m } else { 0 }, if want_u { k } else { 0 });
    let mut v = Mat::<f64>::zeros(if want_v { n } else { 0 }, if want_v { k } else { 0 });
    faer::linalg::svd::svd(
        as_faer(a),
        s.as_mut(),
        want_u.then(|| u.as_mut()),
        want_v.then(|| v.as_mut()),
        par,
        MemStack::new(&mut mem),
        params,
    )
    .map_err(|_| svd_err("faer svd"))?;
    let sv: Vec<f64> = (0..k).map(|i| s.column_vector()[i]).collect();
    Ok((sv, want_u.then_some((u, v))))
}

/// Thin SVD A = U diag(s) Vᵀ.
#[derive(Debug, Clone, PartialEq)]
pub struct Svd {
    /// Left singular vectors, m×k orthonormal columns.
    pub u: DMatrix<f64>,
    /// Singular values, length k = min(m, n), nonincreasing, ≥ 0.
    pub s: DVector<f64>,
    /// Right singular vectors, n×k orthonormal columns.
    pub v: DMatrix<f64>,
}

impl Svd {
    /// Reassembles U diag(s) Vᵀ (O(mnk)).
    pub fn reconstruct(&self) -> DMatrix<f64> {
        let mut us = self.u.clone();
        for (j, mut col) in us.column_iter_mut().enumerate() {
            col *= self.s[j];
        }
        us * self.v.transpose()
    }
}

fn svd_err(what: &'static str) -> Error {
    Error::NoConvergence {
        what,
        iterations: 0,
    }
}

/// Thin SVD of an m×n matrix (faer `thin_svd`, O(mn·min(m,n))).
///
/// Errors: [`Error::NonFinite`], [`Error::NoConvergence`].
pub fn svd(a: &DMatrix<f64>) -> Result<Svd> {
    check_finite("a", a)?;
    let (m, n) = a.shape();
    let k = m.min(n);
    if k == 0 {
        return Ok(Svd {
            u: DMatrix::zeros(m, 0),
            s: DVector::zeros(0),
            v: DMatrix::zeros(n, 0),
        });
    }
    let (sv, uv) = faer_svd(a, Vectors::Both)?;
    let (u, v) = uv.ok_or_else(|| svd_err("faer svd"))?;
    Ok(Svd {
        u: to_dmatrix(u.as_ref()),
        s: DVector::from_vec(sv),
        v: to_dmatrix(v.as_ref()),
    })
}

/// The left singular vectors (m×k, thin) and the singular values
/// (nonincreasing) of an m×n matrix, without V: [`svd`] less the right
/// vectors (≈ 20 % less work on a 40×160 matrix). O(mn·min(m,n)).
///
/// Errors: [`Error::NonFinite`], [`Error::NoConvergence`].
pub fn svd_left(a: &DMatrix<f64>) -> Result<(DMatrix<f64>, DVector<f64>)> {
    check_finite("a", a)?;
    let (m, n) = a.shape();
    if m.min(n) == 0 {
        return Ok((DMatrix::zeros(m, 0), DVector::zeros(0)));
    }
    if n as f64 / m as f64 > QR_RATIO {
        return wide_left(a);
    }
    let (sv, uv) = faer_svd(a, Vectors::Left)?;
    let (u, _) = uv.ok_or_else(|| svd_err("faer svd"))?;
    Ok((to_dmatrix(u.as_ref()), DVector::from_vec(sv)))
}

/// faer's `SvdParams::qr_ratio_threshold` (faer 0.24): a matrix more than
/// this many times wider than tall has its transpose QR-factored first.
const QR_RATIO: f64 = 11.0 / 6.0;

/// [`svd_left`] of a wide m×n matrix (n > 11/6 m) as faer computes it —
/// R of Aᵀ = Q R, then the squareish SVD of the m×m R, whose right vectors
/// are A's left ones (A = Rᵀ Qᵀ) — with R from [`faer_signed_r`] instead of
/// faer's blocked QR of the transposed view, whose scaled norms made it
/// half of a 40×160 SVD (the subspace step's at horizon 20: ≈ 0.15 of
/// 0.35 ms). The same reflections, so the same R and U to rounding (the
/// signs included: a column of U is not flipped). O(2nm² + m³).
fn wide_left(a: &DMatrix<f64>) -> Result<(DMatrix<f64>, DVector<f64>)> {
    let m = a.nrows();
    let r = faer_signed_r(a.transpose());
    let mut mem = MemBuffer::new(svd_scratch::<f64>(
        m,
        m,
        ComputeSvdVectors::No,
        ComputeSvdVectors::Thin,
        Par::Seq,
        Default::default(),
    ));
    let mut s = Diag::<f64>::zeros(m);
    let mut v = Mat::<f64>::zeros(m, m);
    faer::linalg::svd::svd(
        as_faer(&r),
        s.as_mut(),
        None,
        Some(v.as_mut()),
        Par::Seq,
        MemStack::new(&mut mem),
        Default::default(),
    )
    .map_err(|_| svd_err("faer svd"))?;
    let sv: Vec<f64> = (0..m).map(|i| s.column_vector()[i]).collect();
    Ok((to_dmatrix(v.as_ref()), DVector::from_vec(sv)))
}

/// R (k×k, k = ncols) of the tall `t` = Q R by unblocked Householder
/// reflections with faer's convention (`make_householder`: the new
/// diagonal −sign(α)·‖(α, x)‖, no reflection where the column's tail is
/// below the smallest normal number), each column's reflection applied to
/// the later columns as one product and one update over contiguous
/// columns (vector kernels). 2mk² flops.
fn faer_signed_r(mut t: DMatrix<f64>) -> DMatrix<f64> {
    let (m, k) = t.shape();
    crate::simd::dispatch(
        #[inline(always)]
        || {
            for j in 0..k.min(m) {
                let (head, rest) = t.as_mut_slice()[j * m + j..].split_at_mut(m - j);
                let col = &mut head[..];
                let tail_norm = norm2(&col[1..]);
                let mut alpha = col[0];
                if alpha.abs() < f64::MIN_POSITIVE {
                    alpha = 0.0;
                    col[0] = 0.0;
                }
                if tail_norm < f64::MIN_POSITIVE {
                    continue;
                }
                let norm = alpha.abs().hypot(tail_norm);
                let signed = if alpha != 0.0 { alpha.signum() } else { 1.0 } * norm;
                let inv = 1.0 / (alpha + signed);
                for x in &mut col[1..] {
                    *x *= inv;
                }
                col[0] = -signed;
                // H = I − v vᵀ / τ with v = (1, x/(α + β)).
                let tau = 0.5 * (1.0 + (tail_norm * inv.abs()).powi(2));
                let v = &col[1..];
                for c in rest.chunks_exact_mut(m) {
                    let c = &mut c[j..];
                    let w = (c[0] + crate::kernels::dot(v, &c[1..])) / tau;
                    c[0] -= w;
                    for (ci, vi) in c[1..].iter_mut().zip(v) {
                        *ci -= w * vi;
                    }
                }
            }
        },
    );
    DMatrix::from_fn(k, k, |i, j| if i <= j && i < m { t[(i, j)] } else { 0.0 })
}

/// ‖x‖₂: the plain sum of squares where it cannot overflow or underflow
/// harmfully, else scaled by the largest magnitude.
#[inline(always)]
fn norm2(x: &[f64]) -> f64 {
    let ss = crate::kernels::dot(x, x);
    if ss.is_finite() && ss > 1e-290 {
        return ss.sqrt();
    }
    let amax = x.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    if amax == 0.0 || !amax.is_finite() {
        return amax;
    }
    let s = 1.0 / amax;
    amax * x.iter().map(|v| (v * s) * (v * s)).sum::<f64>().sqrt()
}

/// Full SVD: U (m×m), s (min(m,n)), V (n×n); used for null spaces.
pub(crate) fn svd_full(a: &DMatrix<f64>) -> Result<Svd> {
    let (m, n) = a.shape();
    let k = m.min(n);
    if k == 0 {
        return Ok(Svd {
            u: DMatrix::identity(m, m),
            s: DVector::zeros(0),
            v: DMatrix::identity(n, n),
        });
    }
    let f = as_faer(a).svd().map_err(|_| svd_err("faer svd"))?;
    let s = f.S().column_vector();
    Ok(Svd {
        u: to_dmatrix(f.U()),
        s: DVector::from_fn(k, |i, _| s[i]),
        v: to_dmatrix(f.V()),
    })
}

/// Singular values only, nonincreasing (faer `singular_values`,
/// O(mn·min(m,n)) without the vector updates).
///
/// Errors: [`Error::NonFinite`], [`Error::NoConvergence`].
pub fn singular_values(a: &DMatrix<f64>) -> Result<DVector<f64>> {
    check_finite("a", a)?;
    if a.nrows().min(a.ncols()) == 0 {
        return Ok(DVector::zeros(0));
    }
    let (mut s, _) = faer_svd(a, Vectors::None)?;
    s.sort_by(|x, y| y.total_cmp(x));
    Ok(DVector::from_vec(s))
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn diagonal_svd() {
        let a = DMatrix::from_row_slice(3, 2, &[0.0, 3.0, 4.0, 0.0, 0.0, 0.0]);
        let f = svd(&a).unwrap();
        assert_relative_eq!(f.s, DVector::from_vec(vec![4.0, 3.0]), epsilon = 1e-15);
        assert_relative_eq!(f.reconstruct(), a, epsilon = 1e-14);
        assert_relative_eq!(singular_values(&a).unwrap(), f.s, epsilon = 1e-15);
    }

    /// The wide path (R of Aᵀ by the reflections of faer's convention,
    /// then faer's squareish SVD) gives faer's own wide SVD: the same
    /// singular values and left vectors, signs included, to rounding — on
    /// random matrices of several shapes (the subspace step's 40×160 and
    /// its zero columns among them) and at tiny and huge scales.
    #[test]
    fn the_wide_path_gives_faers_left_vectors() {
        let mut state = 7u64;
        let mut rnd = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for (m, n, scale) in [
            (40, 160, 1.0),
            (40, 120, 1.0),
            (12, 30, 1.0),
            (8, 100, 1.0),
            (3, 6, 1.0),
            (1, 5, 1.0),
            (20, 80, 1e-150),
            (20, 80, 1e120),
        ] {
            for trial in 0..3 {
                let mut a = DMatrix::from_fn(m, n, |_, _| rnd() * scale);
                if trial == 1 {
                    // The subspace step's zero columns.
                    a.columns_mut(n - n / 4, n / 4).fill(0.0);
                }
                let (s_faer, uv) = faer_svd(&a, Vectors::Left)
                    .unwrap_or_else(|e| panic!("{m}x{n} {scale:e} {trial}: {e}"));
                let u_faer = to_dmatrix(uv.unwrap().0.as_ref());
                let (u, s) = wide_left(&a).unwrap();
                for j in 0..m {
                    let rel = (s[j] - s_faer[j]).abs() / s_faer[0];
                    assert!(rel < 1e-12, "{m}x{n}: s[{j}] {} vs {}", s[j], s_faer[j]);
                    let d = (u.column(j) - u_faer.column(j)).amax();
                    assert!(
                        d < 1e-8,
                        "{m}x{n} trial {trial}: column {j} differs by {d:e}"
                    );
                }
            }
        }
    }

    #[test]
    fn left_vectors_equal_those_of_the_full_svd() {
        for (m, n) in [(4, 9), (9, 4), (6, 6)] {
            let a = DMatrix::from_fn(m, n, |i, j| {
                ((i * 7 + j * 3) % 5) as f64 - 2.0 + 0.1 * j as f64
            });
            let full = svd(&a).unwrap();
            let (u, s) = svd_left(&a).unwrap();
            assert_relative_eq!(s, full.s, epsilon = 1e-12);
            // Same columns up to sign (distinct singular values).
            for j in 0..s.len() {
                let sign = u.column(j).dot(&full.u.column(j)).signum();
                assert_relative_eq!(
                    u.column(j) * sign,
                    full.u.column(j).into_owned(),
                    epsilon = 1e-10
                );
            }
        }
        let (u, s) = svd_left(&DMatrix::zeros(3, 0)).unwrap();
        assert_eq!((u.shape(), s.len()), ((3, 0), 0));
    }

    #[test]
    fn empty_shapes() {
        let f = svd(&DMatrix::zeros(4, 0)).unwrap();
        assert_eq!((f.u.shape(), f.s.len(), f.v.shape()), ((4, 0), 0, (0, 0)));
        assert_eq!(singular_values(&DMatrix::zeros(0, 3)).unwrap().len(), 0);
    }
}

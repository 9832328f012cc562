//! Real Schur form A = Q T Qᵀ, its eigenvalues, reordering, and the complex
//! Schur form derived from it.
//!
//! The decomposition is nalgebra's Francis double-shift QR on the Hessenberg
//! form (faer 0.24 keeps its real Schur private), O(10n³). The result is
//! *standardised*: entries below the first subdiagonal are exactly zero, a
//! nonzero subdiagonal entry marks a 2×2 block, and every 2×2 block has a
//! complex-conjugate pair of eigenvalues (blocks with real eigenvalues are
//! split by a Givens rotation as LAPACK's `dlanv2` does).
//!
//! [`RealSchur::reorder`] moves selected eigenvalues to the leading block by
//! swapping adjacent 1×1/2×2 blocks with orthogonal transformations
//! (Bai & Demmel 1993, LAPACK `dtrexc`/`dlaexc`), O(n²) per swap.

use nalgebra::{DMatrix, Matrix2};
use num_complex::Complex64;

use crate::check::square_finite;
use crate::{Error, Result};

/// A real Schur decomposition A = Q T Qᵀ: Q orthogonal, T quasi-upper-
/// triangular with 1×1 blocks (real eigenvalues) and 2×2 blocks (complex
/// pairs) on its diagonal.
#[derive(Debug, Clone, PartialEq)]
pub struct RealSchur {
    /// The orthogonal factor Q (n×n).
    pub q: DMatrix<f64>,
    /// The quasi-upper-triangular factor T (n×n).
    pub t: DMatrix<f64>,
}

/// Computes the real Schur form of a square matrix (O(10n³)).
///
/// Errors: [`Error::NotSquare`], [`Error::NonFinite`],
/// [`Error::NoConvergence`] if the QR iteration does not converge.
pub fn real_schur(a: &DMatrix<f64>) -> Result<RealSchur> {
    let n = square_finite("a", a)?;
    let max_iter = 100 * n + 100;
    let schur = a
        .clone()
        .try_schur(f64::EPSILON, max_iter)
        .ok_or(Error::NoConvergence {
            what: "real Schur QR iteration",
            iterations: max_iter,
        })?;
    let (q, t) = schur.unpack();
    let mut rs = RealSchur { q, t };
    rs.standardise();
    if rs.t.iter().chain(rs.q.iter()).any(|v| !v.is_finite()) {
        return Err(Error::Backend {
            what: "real Schur",
            reason: "non-finite result".into(),
        });
    }
    Ok(rs)
}

/// Eigenvalues of the 2×2 matrix [a b; c d], computed stably (`dlanv2`).
/// For a complex pair the one with positive imaginary part comes first.
pub(crate) fn eig2x2(a: f64, b: f64, c: f64, d: f64) -> (Complex64, Complex64) {
    let p = 0.5 * (a - d);
    let bc = b * c;
    let disc = p * p + bc;
    let mean = 0.5 * (a + d);
    if disc >= 0.0 {
        let z = p + p.signum() * disc.sqrt();
        if z == 0.0 {
            return (Complex64::new(mean, 0.0), Complex64::new(mean, 0.0));
        }
        let l1 = d + z;
        let l2 = d - bc / z;
        (Complex64::new(l1, 0.0), Complex64::new(l2, 0.0))
    } else {
        let im = (-disc).sqrt();
        (Complex64::new(mean, im), Complex64::new(mean, -im))
    }
}

/// Applies the plane transformation G (2×2, orthogonal) acting on indices
/// k, k+1 as T ← Gᵀ T G, Q ← Q G.
fn rotate(t: &mut DMatrix<f64>, q: &mut DMatrix<f64>, k: usize, g: &Matrix2<f64>) {
    let n = t.nrows();
    for j in 0..n {
        let (x, y) = (t[(k, j)], t[(k + 1, j)]);
        t[(k, j)] = g[(0, 0)] * x + g[(1, 0)] * y;
        t[(k + 1, j)] = g[(0, 1)] * x + g[(1, 1)] * y;
    }
    for m in [&mut *t, &mut *q] {
        for i in 0..n {
            let (x, y) = (m[(i, k)], m[(i, k + 1)]);
            m[(i, k)] = x * g[(0, 0)] + y * g[(1, 0)];
            m[(i, k + 1)] = x * g[(0, 1)] + y * g[(1, 1)];
        }
    }
}

impl RealSchur {
    /// Order n.
    fn n(&self) -> usize {
        self.t.nrows()
    }

    /// Zeroes everything below the subdiagonal and splits 2×2 blocks with
    /// real eigenvalues.
    fn standardise(&mut self) {
        let n = self.n();
        for j in 0..n {
            for i in (j + 2)..n {
                self.t[(i, j)] = 0.0;
            }
        }
        let mut k = 0;
        while k + 1 < n {
            if self.t[(k + 1, k)] != 0.0 {
                self.split_if_real(k);
                if self.t[(k + 1, k)] != 0.0 {
                    // Genuine complex 2×2 block: the next block starts at
                    // k+2, so (k+2, k+1) must be zero.
                    if k + 2 < n {
                        self.t[(k + 2, k + 1)] = 0.0;
                    }
                    k += 2;
                    continue;
                }
            }
            k += 1;
        }
    }

    /// If the 2×2 block at k has real eigenvalues, triangularise it.
    fn split_if_real(&mut self, k: usize) {
        let (a, b, c, d) = (
            self.t[(k, k)],
            self.t[(k, k + 1)],
            self.t[(k + 1, k)],
            self.t[(k + 1, k + 1)],
        );
        let (l1, _) = eig2x2(a, b, c, d);
        if l1.im != 0.0 {
            return;
        }
        let l1 = l1.re;
        // Eigenvector of λ₁ from whichever row of (B − λ₁I) is larger.
        let v1 = (b, l1 - a);
        let v2 = (l1 - d, c);
        let v = if v1.0.hypot(v1.1) >= v2.0.hypot(v2.1) {
            v1
        } else {
            v2
        };
        let r = v.0.hypot(v.1);
        if r == 0.0 {
            self.t[(k + 1, k)] = 0.0;
            return;
        }
        let (cs, sn) = (v.0 / r, v.1 / r);
        let g = Matrix2::new(cs, -sn, sn, cs);
        rotate(&mut self.t, &mut self.q, k, &g);
        self.t[(k + 1, k)] = 0.0;
    }

    /// Diagonal blocks as (start, size) pairs, size 1 or 2.
    pub fn blocks(&self) -> Vec<(usize, usize)> {
        let n = self.n();
        let mut out = Vec::new();
        let mut k = 0;
        while k < n {
            let size = if k + 1 < n && self.t[(k + 1, k)] != 0.0 {
                2
            } else {
                1
            };
            out.push((k, size));
            k += size;
        }
        out
    }

    /// Eigenvalues in the order of the diagonal blocks of T; a complex pair
    /// is listed with the positive imaginary part first. O(n).
    pub fn eigenvalues(&self) -> Vec<Complex64> {
        let t = &self.t;
        let mut out = Vec::with_capacity(self.n());
        for (k, size) in self.blocks() {
            if size == 1 {
                out.push(Complex64::new(t[(k, k)], 0.0));
            } else {
                let (l1, l2) = eig2x2(t[(k, k)], t[(k, k + 1)], t[(k + 1, k)], t[(k + 1, k + 1)]);
                out.push(l1);
                out.push(l2);
            }
        }
        out
    }

    /// Reorders the form so that the eigenvalues for which `select` is true
    /// occupy the leading block of T; returns the new form and the number
    /// of selected eigenvalues (the size of that leading block).
    ///
    /// A complex pair is selected together: it moves if `select` is true
    /// for either of its members. The relative order of the selected blocks
    /// is kept (as LAPACK `dtrsen`). Each adjacent swap is an orthogonal
    /// Bai–Demmel swap (O(n) work on the n×n factors per swap, O(n³) in the
    /// worst case overall); a swap whose residual exceeds 100·ε·‖T‖ is
    /// rejected with [`Error::Backend`] (this happens only for eigenvalues
    /// that are extremely close, as in LAPACK).
    pub fn reorder(&self, select: impl Fn(Complex64) -> bool) -> Result<(RealSchur, usize)> {
        let mut rs = self.clone();
        let n = rs.n();
        // Which blocks are selected, decided on the original eigenvalues.
        let blocks = rs.blocks();
        let mut selected_sizes = Vec::new();
        let mut flags = Vec::new();
        for &(k, size) in &blocks {
            let sel = if size == 1 {
                select(Complex64::new(rs.t[(k, k)], 0.0))
            } else {
                let (l1, l2) = eig2x2(
                    rs.t[(k, k)],
                    rs.t[(k, k + 1)],
                    rs.t[(k + 1, k)],
                    rs.t[(k + 1, k + 1)],
                );
                select(l1) || select(l2)
            };
            flags.push(sel);
            if sel {
                selected_sizes.push(size);
            }
        }
        let count: usize = selected_sizes.iter().sum();
        // Bubble each selected block up to position `ks`.
        let mut ks = 0;
        let mut pos = 0;
        for (&(_, size), &sel) in blocks.iter().zip(&flags) {
            if sel {
                let mut here = pos;
                while here > ks {
                    // Block just above `here`: its size is read off T.
                    let above = if here >= 2 && rs.t[(here - 1, here - 2)] != 0.0 {
                        2
                    } else {
                        1
                    };
                    let start = here - above;
                    rs.swap(start, above, size)?;
                    here = start;
                }
                ks += size;
            }
            pos += size;
        }
        debug_assert!(ks == count && pos == n);
        Ok((rs, count))
    }

    /// Swaps the adjacent diagonal blocks T₁₁ (n1×n1, starting at k) and
    /// T₂₂ (n2×n2).
    fn swap(&mut self, k: usize, n1: usize, n2: usize) -> Result<()> {
        let n = self.n();
        let m = n1 + n2;
        let tnorm = self.t.norm().max(f64::MIN_POSITIVE);
        if n1 == 1 && n2 == 1 {
            let (t11, t12, t22) = (self.t[(k, k)], self.t[(k, k + 1)], self.t[(k + 1, k + 1)]);
            let (x, y) = (t12, t22 - t11);
            let r = x.hypot(y);
            if r == 0.0 {
                return Ok(());
            }
            // First column of G spans the eigenvector of t22.
            let g = Matrix2::new(x / r, -y / r, y / r, x / r);
            rotate(&mut self.t, &mut self.q, k, &g);
            self.t[(k, k)] = t22;
            self.t[(k + 1, k + 1)] = t11;
            self.t[(k + 1, k)] = 0.0;
            return Ok(());
        }
        let a11 = self.t.view((k, k), (n1, n1)).into_owned();
        let a12 = self.t.view((k, k + n1), (n1, n2)).into_owned();
        let a22 = self.t.view((k + n1, k + n1), (n2, n2)).into_owned();
        // Solve A11 X − X A22 = −A12 through its Kronecker form.
        let dim = n1 * n2;
        let mut kron = DMatrix::<f64>::zeros(dim, dim);
        for c in 0..n2 {
            for r in 0..n1 {
                let row = c * n1 + r;
                for r2 in 0..n1 {
                    kron[(row, c * n1 + r2)] += a11[(r, r2)];
                }
                for c2 in 0..n2 {
                    kron[(row, c2 * n1 + r)] -= a22[(c2, c)];
                }
            }
        }
        let rhs: Vec<f64> = (0..dim).map(|i| -a12[(i % n1, i / n1)]).collect();
        let xv = small_solve(kron, rhs);
        // [X  I_n1; I_n2  0]: nonsingular, its first n2 columns span the
        // invariant subspace of A22.
        let mut basis = DMatrix::<f64>::zeros(m, m);
        for c in 0..n2 {
            for r in 0..n1 {
                basis[(r, c)] = xv[c * n1 + r];
            }
            basis[(n1 + c, c)] = 1.0;
        }
        for r in 0..n1 {
            basis[(r, n2 + r)] = 1.0;
        }
        let g = basis.qr().q();
        // Apply T ← Gᵀ T G on rows/cols k..k+m, Q ← Q G.
        let rows = self.t.rows(k, m).into_owned();
        self.t.rows_mut(k, m).copy_from(&(g.transpose() * rows));
        let cols = self.t.columns(k, m).into_owned();
        self.t.columns_mut(k, m).copy_from(&(cols * &g));
        let qcols = self.q.columns(k, m).into_owned();
        self.q.columns_mut(k, m).copy_from(&(qcols * &g));
        // The block now below the diagonal must be negligible.
        let resid = self.t.view((k + n2, k), (n1, n2)).norm();
        if resid.is_nan() || resid > 100.0 * f64::EPSILON * tnorm {
            return Err(Error::Backend {
                what: "Schur reorder",
                reason: format!("swap at {k} rejected, residual {resid:e}"),
            });
        }
        self.t.view_mut((k + n2, k), (n1, n2)).fill(0.0);
        // Clean the parts below the new diagonal blocks.
        for (start, size) in [(k, n2), (k + n2, n1)] {
            if size == 1 {
                continue;
            }
            self.split_if_real(start);
        }
        if n2 == 1 && k + 1 < n {
            self.t[(k + 1, k)] = 0.0;
        }
        Ok(())
    }

    /// Unitary reduction of the real Schur form to the complex (upper
    /// triangular) Schur form A = U T Uᴴ (MATLAB `rsf2csf`), O(n²).
    pub fn to_complex(&self) -> (DMatrix<Complex64>, DMatrix<Complex64>) {
        let n = self.n();
        let mut t = self.t.map(|v| Complex64::new(v, 0.0));
        let mut u = self.q.map(|v| Complex64::new(v, 0.0));
        for (k, size) in self.blocks() {
            if size == 1 {
                continue;
            }
            let (a, b, c, d) = (t[(k, k)], t[(k, k + 1)], t[(k + 1, k)], t[(k + 1, k + 1)]);
            let (lam, _) = eig2x2(a.re, b.re, c.re, d.re);
            let v1 = (b, lam - a);
            let v2 = (lam - d, c);
            let nrm = |v: &(Complex64, Complex64)| (v.0.norm_sqr() + v.1.norm_sqr()).sqrt();
            let v = if nrm(&v1) >= nrm(&v2) { v1 } else { v2 };
            let r = nrm(&v);
            let (v0, v1) = (v.0 / r, v.1 / r);
            // G = [v0 −conj(v1); v1 conj(v0)], T ← Gᴴ T G.
            for j in 0..n {
                let (x, y) = (t[(k, j)], t[(k + 1, j)]);
                t[(k, j)] = v0.conj() * x + v1.conj() * y;
                t[(k + 1, j)] = -v1 * x + v0 * y;
            }
            for m in [&mut t, &mut u] {
                for i in 0..n {
                    let (x, y) = (m[(i, k)], m[(i, k + 1)]);
                    m[(i, k)] = x * v0 + y * v1;
                    m[(i, k + 1)] = -x * v1.conj() + y * v0.conj();
                }
            }
            t[(k, k)] = lam;
            t[(k + 1, k + 1)] = lam.conj();
            t[(k + 1, k)] = Complex64::new(0.0, 0.0);
        }
        (u, t)
    }
}

/// Solves a tiny (≤ 4×4) system by Gaussian elimination with complete
/// pivoting; tiny pivots are replaced by ε·max|M| (as LAPACK `dlasy2`) so
/// the swap of blocks with (nearly) equal eigenvalues still proceeds.
fn small_solve(mut m: DMatrix<f64>, mut rhs: Vec<f64>) -> Vec<f64> {
    let n = rhs.len();
    let smin = (f64::EPSILON * m.amax()).max(f64::MIN_POSITIVE);
    let mut colperm: Vec<usize> = (0..n).collect();
    for p in 0..n {
        let (mut bi, mut bj, mut bv) = (p, p, -1.0);
        for i in p..n {
            for j in p..n {
                if m[(i, j)].abs() > bv {
                    (bi, bj, bv) = (i, j, m[(i, j)].abs());
                }
            }
        }
        m.swap_rows(p, bi);
        rhs.swap(p, bi);
        m.swap_columns(p, bj);
        colperm.swap(p, bj);
        if m[(p, p)].abs() < smin {
            m[(p, p)] = smin;
        }
        for i in (p + 1)..n {
            let f = m[(i, p)] / m[(p, p)];
            for j in p..n {
                m[(i, j)] -= f * m[(p, j)];
            }
            rhs[i] -= f * rhs[p];
        }
    }
    let mut y = vec![0.0; n];
    for i in (0..n).rev() {
        let s: f64 = ((i + 1)..n).map(|j| m[(i, j)] * y[j]).sum();
        y[i] = (rhs[i] - s) / m[(i, i)];
    }
    let mut x = vec![0.0; n];
    for (p, &c) in colperm.iter().enumerate() {
        x[c] = y[p];
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random(n: usize, seed: u64) -> DMatrix<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        DMatrix::from_fn(n, n, |_, _| rng.random::<f64>() * 2.0 - 1.0)
    }

    fn check_form(a: &DMatrix<f64>, rs: &RealSchur) {
        let n = a.nrows();
        let tol = 100.0 * (n.max(1) as f64) * f64::EPSILON * a.norm().max(1.0);
        assert_relative_eq!(&rs.q * &rs.t * rs.q.transpose(), a.clone(), epsilon = tol);
        assert_relative_eq!(
            rs.q.transpose() * &rs.q,
            DMatrix::identity(n, n),
            epsilon = 100.0 * n as f64 * f64::EPSILON
        );
        for j in 0..n {
            for i in (j + 2)..n {
                assert_eq!(rs.t[(i, j)], 0.0);
            }
        }
        for (k, size) in rs.blocks() {
            if size == 2 {
                let t = &rs.t;
                let (l, _) = eig2x2(t[(k, k)], t[(k, k + 1)], t[(k + 1, k)], t[(k + 1, k + 1)]);
                assert!(l.im != 0.0, "2x2 block with real eigenvalues at {k}");
                if k + 2 < n {
                    assert_eq!(t[(k + 2, k + 1)], 0.0);
                }
            }
        }
    }

    #[test]
    fn schur_of_random_matrices() {
        for (n, seed) in [(1, 1), (2, 2), (3, 3), (6, 4), (17, 5)] {
            let a = random(n, seed);
            let rs = real_schur(&a).unwrap();
            check_form(&a, &rs);
            assert_eq!(rs.eigenvalues().len(), n);
        }
    }

    #[test]
    fn reorder_moves_selected_blocks() {
        for seed in 0..8 {
            let a = random(9, 100 + seed);
            let rs = real_schur(&a).unwrap();
            let ev = rs.eigenvalues();
            let inside = |l: Complex64| l.norm() < 0.8;
            let expected = ev.iter().filter(|l| inside(**l)).count();
            let (rs2, count) = rs.reorder(inside).unwrap();
            assert_eq!(count, expected);
            check_form(&a, &rs2);
            let ev2 = rs2.eigenvalues();
            for (i, l) in ev2.iter().enumerate() {
                assert_eq!(
                    inside(*l),
                    i < count,
                    "eigenvalue {l} at {i}, count {count}"
                );
            }
            // Same spectrum.
            let mut s1: Vec<f64> = ev.iter().map(|l| l.re + 3.0 * l.im.abs()).collect();
            let mut s2: Vec<f64> = ev2.iter().map(|l| l.re + 3.0 * l.im.abs()).collect();
            s1.sort_by(f64::total_cmp);
            s2.sort_by(f64::total_cmp);
            for (x, y) in s1.iter().zip(&s2) {
                assert!((x - y).abs() < 1e-10);
            }
        }
    }

    #[test]
    fn complex_form_is_triangular() {
        let a = random(7, 9);
        let rs = real_schur(&a).unwrap();
        let (u, t) = rs.to_complex();
        let ac = a.map(|v| Complex64::new(v, 0.0));
        let back = &u * &t * u.adjoint();
        assert!((back - ac).norm() < 1e-13 * 7.0);
        for j in 0..7 {
            for i in (j + 1)..7 {
                assert_eq!(t[(i, j)], Complex64::new(0.0, 0.0));
            }
        }
    }

    #[test]
    fn rotation_eigenvalues() {
        let a = DMatrix::from_row_slice(2, 2, &[0.0, -1.0, 1.0, 0.0]);
        let ev = real_schur(&a).unwrap().eigenvalues();
        assert_relative_eq!(ev[0].im.abs(), 1.0, epsilon = 1e-15);
        assert_relative_eq!(ev[0].re, 0.0, epsilon = 1e-15);
    }

    #[test]
    fn rejects_bad_input() {
        assert!(matches!(
            real_schur(&DMatrix::zeros(2, 3)),
            Err(Error::NotSquare { .. })
        ));
        let mut a = DMatrix::<f64>::identity(2, 2);
        a[(0, 1)] = f64::NAN;
        assert!(matches!(real_schur(&a), Err(Error::NonFinite { .. })));
    }

    #[test]
    fn hard_cases_converge() {
        // Cyclic permutation (stalls Francis QR without exceptional shifts),
        // a nilpotent Jordan block, the companion matrix of (z − 0.5)⁴ and
        // the zero matrix.
        let n = 5;
        let perm = DMatrix::from_fn(n, n, |i, j| if (i + 1) % n == j { 1.0 } else { 0.0 });
        let jordan = DMatrix::from_fn(4, 4, |i, j| if j == i + 1 { 1.0 } else { 0.0 });
        let companion = DMatrix::from_row_slice(
            4,
            4,
            &[
                2.0, -1.5, 0.5, -0.0625, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0,
            ],
        );
        for a in [perm, jordan, companion, DMatrix::zeros(3, 3)] {
            let rs = real_schur(&a).unwrap();
            check_form(&a, &rs);
        }
    }
}

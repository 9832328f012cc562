//! Internal façade over `lifted-linalg`: the only place this crate touches
//! dense kernels, so every algorithm below calls one name.

use nalgebra::DMatrix;
use num_complex::Complex64;

use crate::Result;

pub(crate) use lifted_linalg::{check_cols, check_finite, check_rows, check_square};

/// Eigenvalues of a square matrix (unsorted).
pub(crate) fn eigenvalues(a: &DMatrix<f64>) -> Result<Vec<Complex64>> {
    Ok(lifted_linalg::eigenvalues(a)?)
}

/// Solves A X = B (LU; `Singular` when ill-conditioned beyond 1/ε).
pub(crate) fn solve(a: &DMatrix<f64>, b: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    Ok(lifted_linalg::solve(a, b)?)
}

/// Inverse.
pub(crate) fn inv(a: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    Ok(lifted_linalg::inv(a)?)
}

/// Matrix exponential.
pub(crate) fn expm(a: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    Ok(lifted_linalg::expm(a)?)
}

/// Principal matrix logarithm (`NoPrincipalBranch` on ℝ⁻ ∪ {0}).
pub(crate) fn logm(a: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    Ok(lifted_linalg::logm(a)?)
}

/// Symmetric eigendecomposition, descending: (values, vectors).
pub(crate) fn sym_eig_desc(a: &DMatrix<f64>) -> Result<(Vec<f64>, DMatrix<f64>)> {
    let e = lifted_linalg::sym_eig(a, lifted_linalg::SortOrder::Descending)?;
    Ok((e.values.iter().copied().collect(), e.vectors))
}

// TEMPORARY (until lifted-linalg lands these): nalgebra-based stand-ins.
// Each is replaced by a direct call to lifted_linalg before finishing.

/// Thin SVD (u, s descending, v).
pub(crate) fn svd(a: &DMatrix<f64>) -> Result<(DMatrix<f64>, Vec<f64>, DMatrix<f64>)> {
    check_finite("svd", a)?;
    let (m, n) = a.shape();
    let k = m.min(n);
    if k == 0 {
        return Ok((DMatrix::zeros(m, 0), vec![], DMatrix::zeros(n, 0)));
    }
    let s = a.clone().svd(true, true);
    let u = s.u.unwrap_or_else(|| DMatrix::zeros(m, k));
    let vt = s.v_t.unwrap_or_else(|| DMatrix::zeros(k, n));
    let mut idx: Vec<usize> = (0..k).collect();
    idx.sort_by(|&i, &j| s.singular_values[j].total_cmp(&s.singular_values[i]));
    let uu = DMatrix::from_fn(m, k, |r, c| u[(r, idx[c])]);
    let vv = DMatrix::from_fn(n, k, |r, c| vt[(idx[c], r)]);
    let ss = idx.iter().map(|&i| s.singular_values[i]).collect();
    Ok((uu, ss, vv))
}

/// Full QR: orthogonal Q (m×m).
pub(crate) fn qr_full_q(a: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    check_finite("qr", a)?;
    let m = a.nrows();
    if a.ncols() == 0 || m == 0 {
        return Ok(DMatrix::identity(m, m));
    }
    // Householder QR of [A, I]-padded matrix gives a full Q.
    let mut big = DMatrix::zeros(m, a.ncols().max(m));
    big.view_mut((0, 0), (m, a.ncols())).copy_from(a);
    let q = big.qr().q();
    Ok(q.columns(0, m).into_owned())
}

/// Continuous Lyapunov: A X + X Aᵀ + Q = 0 (Kronecker stand-in).
pub(crate) fn lyap(a: &DMatrix<f64>, q: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let n = check_square("lyap", a)?;
    let i = DMatrix::<f64>::identity(n, n);
    let k = i.kronecker(a) + a.kronecker(&i);
    let rhs = DMatrix::from_column_slice(n * n, 1, (-q).as_slice());
    let x = solve(&k, &rhs)?;
    let x = DMatrix::from_column_slice(n, n, x.as_slice());
    Ok((&x + x.transpose()) * 0.5)
}

/// Discrete Lyapunov: A X Aᵀ − X + Q = 0 (Kronecker stand-in).
pub(crate) fn dlyap(a: &DMatrix<f64>, q: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let n = check_square("dlyap", a)?;
    let k = a.kronecker(a) - DMatrix::<f64>::identity(n * n, n * n);
    let rhs = DMatrix::from_column_slice(n * n, 1, (-q).as_slice());
    let x = solve(&k, &rhs)?;
    let x = DMatrix::from_column_slice(n, n, x.as_slice());
    Ok((&x + x.transpose()) * 0.5)
}


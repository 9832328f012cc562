//! Internal façade over `lifted-linalg`: the only place this crate touches
//! dense kernels, so every algorithm below calls one name.

use nalgebra::DMatrix;
use num_complex::Complex64;

use crate::Result;

pub(crate) use lifted_linalg::check::{check_cols, check_finite, check_rows, check_square};

// TEMPORARY (until lifted-linalg lands these): nalgebra-based stand-ins.
// Each is replaced by a direct call to lifted_linalg before finishing.

/// Eigenvalues of a square matrix.
pub(crate) fn eigenvalues(a: &DMatrix<f64>) -> Result<Vec<Complex64>> {
    check_square("eigenvalues", a)?;
    check_finite("eigenvalues", a)?;
    if a.nrows() == 0 {
        return Ok(vec![]);
    }
    Ok(a.clone().complex_eigenvalues().iter().copied().collect())
}

/// Solves A X = B.
pub(crate) fn solve(a: &DMatrix<f64>, b: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let n = check_square("solve", a)?;
    check_rows("solve rhs", b, n)?;
    if n == 0 {
        return Ok(b.clone());
    }
    let lu = a.clone().full_piv_lu();
    let d = lu.u().diagonal().iter().fold(f64::INFINITY, |m, x| m.min(x.abs()));
    let big = a.amax().max(f64::MIN_POSITIVE);
    if d <= 1e-14 * big {
        return Err(lifted_linalg::Error::Singular { what: "solve", rcond: d / big }.into());
    }
    lu.solve(b).ok_or_else(|| lifted_linalg::Error::Singular { what: "solve", rcond: 0.0 }.into())
}

/// Inverse.
pub(crate) fn inv(a: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let n = check_square("inv", a)?;
    solve(a, &DMatrix::identity(n, n))
}

/// Matrix exponential.
pub(crate) fn expm(a: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    check_square("expm", a)?;
    check_finite("expm", a)?;
    Ok(a.clone().exp())
}

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

/// Symmetric eigendecomposition, descending: (values, vectors).
pub(crate) fn sym_eig_desc(a: &DMatrix<f64>) -> Result<(Vec<f64>, DMatrix<f64>)> {
    let n = check_square("sym_eig", a)?;
    check_finite("sym_eig", a)?;
    if n == 0 {
        return Ok((vec![], DMatrix::zeros(0, 0)));
    }
    let s = (a + a.transpose()) * 0.5;
    let e = s.symmetric_eigen();
    let mut idx: Vec<usize> = (0..n).collect();
    idx.sort_by(|&i, &j| e.eigenvalues[j].total_cmp(&e.eigenvalues[i]));
    let vals = idx.iter().map(|&i| e.eigenvalues[i]).collect();
    let vecs = DMatrix::from_fn(n, n, |r, c| e.eigenvectors[(r, idx[c])]);
    Ok((vals, vecs))
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

/// Principal matrix logarithm (stand-in: inverse scaling and squaring with a
/// Padé-free Gregory series on a Schur-less square-root iteration).
pub(crate) fn logm(a: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let n = check_square("logm", a)?;
    check_finite("logm", a)?;
    for ev in eigenvalues(a)? {
        if ev.im.abs() <= 1e-12 * ev.norm().max(1e-300) && ev.re <= 0.0 || ev.norm() < 1e-14 {
            return Err(lifted_linalg::Error::NoPrincipalBranch { what: "logm", eigenvalue: ev }.into());
        }
    }
    // Denman–Beavers square roots until close to I, then series of log(I+E).
    let i = DMatrix::<f64>::identity(n, n);
    let mut x = a.clone();
    let mut k = 0;
    while (&x - &i).norm() > 0.1 && k < 60 {
        let mut y = x.clone();
        let mut z = i.clone();
        for _ in 0..100 {
            let yi = inv(&y)?;
            let zi = inv(&z)?;
            let yn = (&y + &zi) * 0.5;
            let zn = (&z + &yi) * 0.5;
            let done = (&yn - &y).norm() <= 1e-15 * yn.norm();
            y = yn;
            z = zn;
            if done {
                break;
            }
        }
        x = y;
        k += 1;
    }
    let e = &x - &i;
    let mut term = e.clone();
    let mut sum = DMatrix::<f64>::zeros(n, n);
    for j in 1..200 {
        let t = &term * (if j % 2 == 1 { 1.0 } else { -1.0 } / j as f64);
        sum += &t;
        if t.norm() < 1e-18 {
            break;
        }
        term = &term * &e;
    }
    Ok(sum * 2f64.powi(k))
}

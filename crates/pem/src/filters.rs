//! Scalar polynomial filters in q⁻¹ and the damped Gauss–Newton step shared
//! by the polynomial prediction-error estimators ([`crate::oe`],
//! [`crate::polyest`]).

use nalgebra::{DMatrix, DVector};

use crate::error::Result;

/// w(t) = s(t − delay) − Σ_j f_j w(t − j), zero initial conditions.
pub(crate) fn filter(s: &[f64], f: &[f64], delay: usize, out: &mut Vec<f64>) {
    out.clear();
    out.resize(s.len(), 0.0);
    for t in 0..s.len() {
        let mut v = if t >= delay { s[t - delay] } else { 0.0 };
        for (j, fj) in f.iter().enumerate() {
            if t > j {
                v -= fj * out[t - j - 1];
            }
        }
        out[t] = v;
    }
}

/// Σ_m b_m v(t − m).
pub(crate) fn fir_apply(v: &[f64], b: &[f64], out: &mut Vec<f64>) {
    out.clear();
    out.resize(v.len(), 0.0);
    for t in 0..v.len() {
        let mut s = 0.0;
        for (m, bm) in b.iter().enumerate() {
            if t >= m {
                s += bm * v[t - m];
            }
        }
        out[t] = s;
    }
}

/// Whether 1 + f₁q⁻¹ + … has every root strictly inside the unit circle.
pub(crate) fn stable(f: &[f64]) -> bool {
    if f.is_empty() {
        return true;
    }
    let n = f.len();
    let companion = DMatrix::from_fn(n, n, |r, c| {
        if r == 0 {
            -f[c]
        } else if r == c + 1 {
            1.0
        } else {
            0.0
        }
    });
    lifted_linalg::spectral_radius(&companion).is_ok_and(|rho| rho < 1.0)
}

/// The Levenberg–Marquardt step δ solving [R₁₁; √λ D] δ = [rhs; 0] in
/// the least-squares sense by a small QR (D = diag(`scale`), Marquardt's
/// scaling); `None` when the damped system is singular. O(d³).
pub(crate) fn damped_step(
    r11: &DMatrix<f64>,
    rhs: &DVector<f64>,
    scale: &[f64],
    lambda: f64,
) -> Result<Option<DVector<f64>>> {
    let d = r11.nrows();
    let mut m = DMatrix::zeros(2 * d, d + 1);
    m.view_mut((0, 0), (d, d)).copy_from(r11);
    for j in 0..d {
        m[(d + j, j)] = lambda.sqrt() * scale[j];
        m[(j, d)] = rhs[j];
    }
    let q = lifted_linalg::qr_r(&m)?;
    Ok(q.view((0, 0), (d, d))
        .into_owned()
        .solve_upper_triangular(&q.view((0, d), (d, 1)).into_owned())
        .map(|v| v.column(0).into_owned()))
}

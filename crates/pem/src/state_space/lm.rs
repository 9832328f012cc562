//! The damped Gauss–Newton (Levenberg–Marquardt) step.

use nalgebra::{DMatrix, DVector};

/// The Levenberg–Marquardt step δ minimising ‖R₁₁ δ + r‖² + λ Σ c_i δ_i²
/// (c_i = diag(JᵀJ), floored at 1e-10 max c_i so that a direction the data
/// do not determine stays damped) by the R-only QR of [R₁₁ −r; √(λc) 0];
/// `None`
/// when the triangular factor is singular or the step not finite. O(p³).
pub(super) fn lm_step(
    r11: &DMatrix<f64>,
    rv: &DVector<f64>,
    lambda: f64,
    colsq: &[f64],
) -> Option<DVector<f64>> {
    let np = r11.ncols();
    let floor = 1e-10 * colsq.iter().copied().fold(0.0, f64::max);
    let mut stacked = DMatrix::zeros(2 * np, np + 1);
    stacked.view_mut((0, 0), (np, np)).copy_from(r11);
    for i in 0..np {
        stacked[(i, np)] = -rv[i];
        stacked[(np + i, i)] = (lambda * colsq[i].max(floor).max(f64::MIN_POSITIVE)).sqrt();
    }
    let r = lifted_linalg::qr_r_owned(stacked).ok()?;
    if r.nrows() < np || (0..np).any(|i| r[(i, i)] == 0.0) {
        return None;
    }
    let tri = r.view((0, 0), (np, np)).upper_triangle();
    let step = tri.solve_upper_triangular(&r.view((0, np), (np, 1)).column(0).into_owned())?;
    step.iter().all(|v| v.is_finite()).then_some(step)
}

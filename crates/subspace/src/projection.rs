//! (B, D) from the compressed data for given (A, C): the MOESP regression on
//! the orthogonal complement of the extended observability matrix
//! (Verhaegen 1994; SLICOT IB01PD), which needs no pass over the records.
//!
//! With the rows of the compressed factor L ordered [U_f; U_p; Y_p; Y_f]
//! (thesis §2.4), the orthogonal projection of the future outputs on the
//! future inputs and the past data is Y_f/[U_f; W_p] = Θ_u U_f + Θ_w W_p,
//! with (Θ_u, Θ_w) = L_{Y_f,1:r} L₁₁⁻¹ (L₁₁ the leading r×r block, r the
//! rows of [U_f; W_p]). In open loop the projection equals
//! Γ_f X̂ + H_f U_f, where H_f is the block lower-triangular Toeplitz matrix
//! of the Markov parameters (D on the diagonal, C A^{m−1} B below), so with
//! Γ⊥ a basis of the left null space of Γ_f
//!
//!   Γ⊥ᵀ Θ_u = Γ⊥ᵀ H_f(B, D),
//!
//! linear in (B, D). Writing Γ⊥ᵀ = [L₀ … L_{f−1}] (blocks of n_y columns),
//! the j-th block column reads M_j = L_j D + N_j B with
//! N_j = Σ_{i>j} L_i C A^{i−j−1}; stacking j = 0 … f−1 gives one least-squares
//! problem per input column (feedthrough entries that the mask fixes at zero
//! are removed from it). The estimate is consistent in open loop for any
//! past horizon: the future innovations are uncorrelated with [U_f; W_p],
//! and whatever the finite past leaves of the state stays in the range of
//! Γ_f, which Γ⊥ annihilates.
//!
//! Inputs with the same feedthrough mask share one regression matrix, so
//! the default (all of D estimated) takes one Householder QR of
//! [K | M₁ … M_{n_u}] whatever n_u.
//!
//! Cost: O(k³) for the coefficients and the null space, O(f n_y (f n_y − n)
//! (n + n_y + n_u)²) for the regression; independent of N.

use lifted_linalg::{
    RAccumulator, RankTolerance, lstsq, null_space, singular_values, triangular_condition,
};
use nalgebra::DMatrix;

use crate::error::{Error, Result};
use crate::hankel::HankelLayout;

/// (B, D) of the scaled data from the compressed factor `l` (layout `lay`;
/// `exact_map` the oblique map 𝓜 = L₃₂ L₂₂⁻¹ when the caller computed it
/// by the triangular solve, see [`future_input_coefficients`]) for (A, C) and the extended observability matrix `gamma` (f n_y × n) of
/// the same scaled data; `mask[(o, j)]` says whether D[o, j] is estimated.
///
/// Errors: [`Error::RankDeficient`] when the regression does not determine
/// (B, D) (f n_y − n too small for n + n_y unknowns per input, or a
/// degenerate Γ), and those of the linear-algebra kernels.
pub(crate) fn bd_from_projection(
    l: &DMatrix<f64>,
    lay: &HankelLayout,
    exact_map: Option<&DMatrix<f64>>,
    a: &DMatrix<f64>,
    c: &DMatrix<f64>,
    gamma: &DMatrix<f64>,
    mask: &DMatrix<bool>,
) -> Result<(DMatrix<f64>, DMatrix<f64>)> {
    let (nu, ny, f) = (lay.nu, lay.ny, lay.future);
    let n = a.nrows();
    let theta_u = future_input_coefficients(l, lay, exact_map)?;
    // Γ⊥ᵀ: rows spanning the left null space of Γ (f n_y − n of them).
    let perp_t = null_space(&gamma.transpose(), RankTolerance::Default)?.transpose();
    let m_rows = perp_t.nrows();
    if m_rows == 0 {
        return Err(Error::RankDeficient {
            what: "projection (B, D) regression: Γ has no left null space (future horizon too short)",
            rank: 0,
            needed: n + ny,
        });
    }
    let m = &perp_t * theta_u;
    // N_j = Σ_{i>j} L_i C A^{i−j−1}, built from the last block backwards:
    // N_{f−1} = 0, N_j = L_{j+1} C + N_{j+1} A.
    let block = |j: usize| perp_t.columns(j * ny, ny).into_owned();
    let mut nj = vec![DMatrix::zeros(m_rows, n); f];
    for j in (0..f - 1).rev() {
        nj[j] = block(j + 1) * c + &nj[j + 1] * a;
    }
    let mut b = DMatrix::zeros(n, nu);
    let mut d = DMatrix::zeros(ny, nu);
    // Inputs whose feedthrough mask is the same share the regressors:
    // one QR of [K | M columns of those inputs] serves them all.
    let mut groups: Vec<(Vec<usize>, Vec<usize>)> = Vec::new();
    for q in 0..nu {
        let outputs: Vec<usize> = (0..ny).filter(|&o| mask[(o, q)]).collect();
        match groups.iter_mut().find(|(outs, _)| *outs == outputs) {
            Some((_, inputs)) => inputs.push(q),
            None => groups.push((outputs, vec![q])),
        }
    }
    for (outputs, inputs) in &groups {
        let unknowns = outputs.len() + n;
        let mut w = DMatrix::zeros(f * m_rows, unknowns + inputs.len());
        for (j, nj) in nj.iter().enumerate() {
            let lj = block(j);
            let r0 = j * m_rows;
            for (t, &o) in outputs.iter().enumerate() {
                w.view_mut((r0, t), (m_rows, 1)).copy_from(&lj.column(o));
            }
            w.view_mut((r0, outputs.len()), (m_rows, n)).copy_from(nj);
            for (g, &q) in inputs.iter().enumerate() {
                w.view_mut((r0, unknowns + g), (m_rows, 1))
                    .copy_from(&m.column(j * nu + q));
            }
        }
        let th = solve_full_rank(w, unknowns)?;
        for (g, &q) in inputs.iter().enumerate() {
            for (t, &o) in outputs.iter().enumerate() {
                d[(o, q)] = th[(t, g)];
            }
            for s in 0..n {
                b[(s, q)] = th[(outputs.len() + s, g)];
            }
        }
    }
    Ok((b, d))
}

/// The least-squares solution of K θ = M for W = [K | M] (K the first
/// `unknowns` columns): one Householder QR of W (R-only, by
/// [`RAccumulator`]: the structured fold for a narrow W, faer's QR
/// otherwise; Qᵀ M comes out as the last columns of R, and θ does not
/// depend on the signs of R's rows), the rank of K from R₁₁ (the default rule of
/// [`RankTolerance`], O(n²) estimates when clearly full rank) and
/// θ = R₁₁⁻¹ R₁₂. O(rows · cols²).
///
/// Errors: [`Error::RankDeficient`] when K does not have full column rank.
fn solve_full_rank(w: DMatrix<f64>, unknowns: usize) -> Result<DMatrix<f64>> {
    let rows = w.nrows();
    let rank_error = |rank| Error::RankDeficient {
        what: "projection (B, D) regression",
        rank,
        needed: unknowns,
    };
    if rows < unknowns {
        return Err(rank_error(rows));
    }
    let mut acc = RAccumulator::new(w.ncols());
    let mut w = w;
    acc.fold_rows(&mut w)?;
    let r = acc.r();
    let r11t = r.view((0, 0), (unknowns, unknowns)).transpose();
    let smax = r11t.norm();
    let thr = RankTolerance::Default.threshold(rows, unknowns, 1.0)?;
    if smax == 0.0 || triangular_condition(&r11t, thr, 10.0)?.ratio <= thr {
        let s = singular_values(&r11t)?;
        let top = s.iter().cloned().fold(0.0, f64::max);
        let tol = RankTolerance::Default.threshold(rows, unknowns, top)?;
        return Err(rank_error(s.iter().filter(|&&v| v > tol).count()));
    }
    let rhs = r.view((0, unknowns), (unknowns, r.ncols() - unknowns));
    r11t.transpose()
        .solve_upper_triangular(&rhs)
        .ok_or_else(|| rank_error(unknowns - 1))
}

/// Θ_u: the coefficients of U_f in the orthogonal projection of Y_f on the
/// rows of [U_f; W_p] (f n_y × f n_u), from the lower-triangular factor:
/// Θ = L_{Y_f,1:r} L₁₁⁻¹ (minimum-norm least squares when the past outputs
/// are rank deficient, e.g. noise-free data; the U_f part is unique as long
/// as the inputs are persistently exciting).
///
/// With L₁₁ = [A 0; B L₂₂] (A the U_f block) and Θ = [Θ_u Θ_w], Θ L₁₁ =
/// L_{Y_f,1:r} reads Θ_w L₂₂ = L₃₂ — the oblique map, Θ_w = 𝓜 — and
/// Θ_u A + 𝓜 B = L_{Y_f,U_f}. So with `exact_map` (𝓜 from the triangular
/// solve) Θ_u = (L_{Y_f,U_f} − 𝓜 B) A⁻¹: one product and an f n_u
/// triangular solve, O(f n_y r_w f n_u). Otherwise one triangular solve
/// with L₁₁ (O(r² f n_y)) or the least squares (O(r³)).
fn future_input_coefficients(
    l: &DMatrix<f64>,
    lay: &HankelLayout,
    exact_map: Option<&DMatrix<f64>>,
) -> Result<DMatrix<f64>> {
    let r = lay.yf().start;
    let yf = lay.yf();
    let ru = lay.uf().len();
    if let Some(map) = exact_map {
        // A is nonsingular: the excitation test certified [U_f; U_p], of
        // which A is a leading block.
        let a = l.view((0, 0), (ru, ru));
        let mut rhs = l.view((yf.start, 0), (yf.len(), ru)).into_owned();
        rhs.gemm(-1.0, map, &l.view((ru, 0), (r - ru, ru)), 1.0);
        if let Some(theta) = lifted_linalg::solve_right_lower(&a.into_owned(), rhs) {
            return Ok(theta);
        }
    }
    let l11 = l.view((0, 0), (r, r)).into_owned();
    let l21 = l.view((yf.start, 0), (yf.len(), r)).into_owned();
    // Θ L₁₁ = L₂₁  ⇔  L₁₁ᵀ Θᵀ = L₂₁ᵀ. A lower-triangular L₁₁ (the factor's
    // usual shape) of full rank by lstsq's rule takes one triangular solve
    // (O(r² f n_y)); otherwise the minimum-norm least squares.
    let triangular = (0..r).all(|j| (0..j).all(|i| l11[(i, j)] == 0.0));
    if triangular {
        let thr = RankTolerance::Default.threshold(r, r, 1.0)?;
        if triangular_condition(&l11, thr, 10.0)?.ratio > thr
            && let Some(theta) = lifted_linalg::solve_right_lower(&l11, l21.clone())
        {
            return Ok(theta.columns(0, lay.uf().len()).into_owned());
        }
    }
    let theta = lstsq(&l11.transpose(), &l21.transpose())?.transpose();
    Ok(theta.columns(0, lay.uf().len()).into_owned())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::oblique::Projector;
    use approx::assert_relative_eq;

    #[test]
    fn coefficients_from_the_oblique_map_equal_the_direct_solve() {
        let lay = HankelLayout {
            past: 3,
            future: 4,
            nu: 2,
            ny: 1,
        };
        let k = lay.yf().end;
        let mut s: u64 = 0x9E37_79B9_7F4A_7C15;
        let l = DMatrix::from_fn(k, k, |i, j| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let r = (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            match i.cmp(&j) {
                std::cmp::Ordering::Greater => r,
                std::cmp::Ordering::Equal => 1.0 + r.abs(),
                std::cmp::Ordering::Less => 0.0,
            }
        });
        let pr = Projector::new(&l, lay, 0.0).unwrap();
        let (map, triangular) = pr.oblique_map().unwrap();
        assert!(triangular);
        let via_map = future_input_coefficients(&l, &lay, Some(&map)).unwrap();
        let direct = future_input_coefficients(&l, &lay, None).unwrap();
        assert_eq!(via_map.shape(), (lay.yf().len(), lay.uf().len()));
        assert_relative_eq!(via_map, direct, epsilon = 1e-10);
    }
}

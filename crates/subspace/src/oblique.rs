//! Orthogonal and oblique projections of the compressed block-Hankel data.
//!
//! The rows of the compressed factor L (k×k, k = (p+f)(n_u+n_y)) stand for
//! the block rows [U_f; U_p; Y_p; Y_f] of the data (H = L Qᵀ with Q
//! orthonormal columns), so every projection of H acts on the rows of L.
//! L is lower triangular (Cholesky of the correlations, or Rᵀ of the R-only
//! QR): the rows of U_f then span exactly the first r_u = f n_u coordinates
//! as soon as their leading block L₁₁ is nonsingular, which the persistent
//! excitation test of [`crate::identify`] establishes before any projection
//! (σ_min(L₁₁) ≥ σ_min of the whole input block, a leading block of a
//! triangular matrix). Then, with W_p = [U_p; Y_p] rows r_u … r_w and Y_f the
//! rest:
//!
//! * M Π_{U_f⊥} (the rows of M with U_f's row space removed) is M with its
//!   first r_u columns set to zero: O(k r_u) instead of an SVD of U_fᵀ;
//! * the oblique projection Y_f /_{U_f} W_p = 𝓜 W_p (thesis eq. 2.15) has
//!   the map 𝓜 = (Y_f Π⊥ W_pᵀ)(W_p Π⊥ W_pᵀ)⁺ = L₃₂ L₂₂ᵀ (L₂₂ L₂₂ᵀ)⁺ with L₂₂ the
//!   diagonal W_p block and L₃₂ the Y_f rows under it; when L₂₂ is well
//!   conditioned (σ_min/σ_max above 10⁻⁶, the pseudo-inverse's tolerance of
//!   10⁻¹² on the Gram) this is the triangular solve 𝓜 = L₃₂ L₂₂⁻¹, O(r_w² n),
//!   else the pseudo-inverse of the Gram as in the general formula.
//!
//! A factor without that structure (or the general [`perp`] and
//! [`oblique_map`] on arbitrary rows) goes through the SVD-based range
//! basis, O(k r_u²) per projection.

use lifted_linalg::{
    RankTolerance, lower_inverse_frobenius, pinv, range_basis, ratio_bound, solve_right_lower,
    triangular_condition,
};
use nalgebra::DMatrix;

use crate::error::Result;
use crate::hankel::HankelLayout;

/// Removes the row space of `u` from the rows of `m`: m Π_{u⊥}. One thin
/// SVD of uᵀ, O(k r²) for r rows of u.
pub(crate) fn perp(m: &DMatrix<f64>, u: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    if u.nrows() == 0 {
        return Ok(m.clone());
    }
    let q = range_basis(&u.transpose(), RankTolerance::Default)?;
    Ok(m - (m * &q) * q.transpose())
}

/// The map 𝓜 of the oblique projection F /_U P = 𝓜 P,
/// 𝓜 = (F Π⊥ Pᵀ)(P Π⊥ Pᵀ)⁺. Three thin SVDs, O(k r²).
pub(crate) fn oblique_map(
    f: &DMatrix<f64>,
    u: &DMatrix<f64>,
    p: &DMatrix<f64>,
) -> Result<DMatrix<f64>> {
    let fp = perp(f, u)?;
    let pp = perp(p, u)?;
    let g = &pp * pp.transpose();
    Ok(fp * pp.transpose() * pinv(&g, RankTolerance::Relative(1e-12))?)
}

/// The projections of one compressed factor L with its layout: which of the
/// structured shortcuts of the module docs apply, decided once.
pub(crate) struct Projector<'a> {
    l: &'a DMatrix<f64>,
    lay: HankelLayout,
    /// The U_f rows of L vanish beyond column r_u and [U_f; W_p] beyond
    /// column r_w (lower-triangular factor).
    structured: bool,
    /// Certified lower bounds of σ_min/σ_max of two diagonal blocks of a
    /// lower-triangular L.
    blocks: Option<BlockRatios>,
}

/// Lower bounds of σ_min/σ_max of two diagonal blocks of a lower-triangular
/// L: the input rows L_uu ([U_f; U_p], the persistent-excitation test) and
/// L₂₂ (W_p, the oblique projection). Either from the factor's certificate
/// ([`block_ratio_floor`], no work) or from two explicit triangular
/// inverses (O(r³/3) each, [`ratio_bound`]).
#[derive(Debug, Clone, Copy)]
struct BlockRatios {
    uu: f64,
    r22: f64,
}

/// A lower bound of σ_min/σ_max of every diagonal block of a k×k
/// lower-triangular L from a proven λ_min/λ_max ≥ `certified` of the
/// matrix G it factors (G ≈ L Lᵀ; [`crate::HankelFactor::certified_rcond`]);
/// 0 when nothing is certified. A diagonal block L_bb has L_bb L_bbᵀ = S,
/// the Schur complement of the leading block in the leading principal
/// submatrix M of G that ends with the block: λ_min(S) ≥ λ_min(M) ≥
/// λ_min(G) (S⁻¹ is a principal submatrix of M⁻¹; Cauchy interlacing) and
/// λ_max(S) ≤ λ_max(M_bb) ≤ λ_max(G) (S = M_bb less a positive
/// semi-definite term), so σ_min(L_bb)²/σ_max(L_bb)² ≥ λ_min(G)/λ_max(G).
/// The certificate holds for the stored G and L Lᵀ = G + E with ‖E‖₂ of
/// order k² u ‖G‖₂ (Higham 2002, Theorem 10.3), the shifted factorisation's
/// own backward error as large: 4k²u is given away (2·10⁻¹¹ at k = 160,
/// against the correlation route's 10⁻⁸).
pub(crate) fn block_ratio_floor(certified: f64, k: usize) -> f64 {
    let slack = 4.0 * (k * k) as f64 * f64::EPSILON;
    if certified.is_finite() && certified > slack {
        (certified - slack).sqrt()
    } else {
        0.0
    }
}

impl<'a> Projector<'a> {
    /// Inspects L (O(k²)) and, when it is lower triangular, bounds the
    /// conditioning of its diagonal blocks L_uu and L₂₂: from `certified`
    /// (a proven lower bound of λ_min/λ_max of L Lᵀ,
    /// [`crate::HankelFactor::certified_rcond`]; 0 when there is none) by
    /// [`block_ratio_floor`], else by inverting the blocks (O(k³/3)). The
    /// U_f rows must be persistently exciting (the caller's test,
    /// [`Projector::input_rank`]) for the structured projection to be exact.
    ///
    /// Errors: [`crate::Error::Linalg`] for a non-finite factor.
    pub(crate) fn new(l: &'a DMatrix<f64>, lay: HankelLayout, certified: f64) -> Result<Self> {
        let k = l.nrows();
        let (ru, rw) = (lay.uf().end, lay.yf().start);
        let zero = |r: usize, c: usize, nr: usize, nc: usize| {
            l.view((r, c), (nr, nc)).iter().all(|&v| v == 0.0)
        };
        let structured = l.ncols() == k
            && rw <= k
            && zero(0, ru, ru, k - ru)
            && zero(ru, rw, rw - ru, k - rw)
            && (ru..rw).all(|i| zero(i, i + 1, 1, rw - i - 1));
        // The input block [U_f; U_p] is lower triangular as soon as L is.
        let uu_rows = lay.up().end;
        let lower =
            structured && uu_rows <= k && (ru..uu_rows).all(|i| zero(i, i + 1, 1, uu_rows - i - 1));
        let floor = block_ratio_floor(certified, k);
        let blocks = if !lower {
            None
        } else if floor > 0.0 {
            Some(BlockRatios {
                uu: floor,
                r22: floor,
            })
        } else {
            let uu = l.view((0, 0), (uu_rows, uu_rows)).into_owned();
            let l22 = l.view((ru, ru), (rw - ru, rw - ru)).into_owned();
            Some(BlockRatios {
                uu: ratio_bound(lower_inverse_frobenius(&uu)?, uu.norm()),
                r22: ratio_bound(lower_inverse_frobenius(&l22)?, l22.norm()),
            })
        };
        Ok(Projector {
            l,
            lay,
            structured,
            blocks,
        })
    }

    /// Numerical rank of the input rows [U_f; U_p] (the leading
    /// n_u(p+f) × n_u(p+f) block of L) by [`crate::numerics::numerical_rank`]'s
    /// rule at the relative threshold `rel`: full when the certified bound
    /// of the block's inverse clears it (no further work), else that
    /// function's estimates and singular values.
    ///
    /// Errors: those of the linear-algebra kernels.
    pub(crate) fn input_rank(&self, rel: f64) -> Result<usize> {
        let r = self.lay.up().end.min(self.l.nrows());
        if let Some(b) = self.blocks
            && b.uu > rel
        {
            return Ok(r);
        }
        crate::numerics::numerical_rank(&self.l.view((0, 0), (r, r)).into_owned(), rel)
    }

    fn rows(&self, r: std::ops::Range<usize>) -> DMatrix<f64> {
        self.l.rows(r.start, r.len()).into_owned()
    }

    /// m Π_{U_f⊥} for a matrix m in the coordinates of L's columns.
    pub(crate) fn perp_future_inputs(&self, m: &DMatrix<f64>) -> Result<DMatrix<f64>> {
        if self.structured {
            let mut out = m.clone();
            out.columns_mut(0, self.lay.uf().end).fill(0.0);
            Ok(out)
        } else {
            perp(m, &self.rows(self.lay.uf()))
        }
    }

    /// The map 𝓜 (f n_y × p(n_u+n_y)) of Y_f /_{U_f} W_p = 𝓜 W_p, and
    /// whether it is the triangular solve 𝓜 = L₃₂ L₂₂⁻¹ (structured factor,
    /// well-conditioned L₂₂) rather than the pseudo-inverse formula.
    pub(crate) fn oblique_map(&self) -> Result<(DMatrix<f64>, bool)> {
        let (ru, rw, k) = (self.lay.uf().end, self.lay.yf().start, self.l.nrows());
        if !self.structured {
            let wp = self.rows(ru..rw);
            let m = oblique_map(&self.rows(self.lay.yf()), &self.rows(self.lay.uf()), &wp)?;
            return Ok((m, false));
        }
        let l22 = self.l.view((ru, ru), (rw - ru, rw - ru)).into_owned();
        let l32 = self.l.view((rw, ru), (k - rw, rw - ru)).into_owned();
        // Same rank decision as the Gram's pseudo-inverse: σ(L₂₂)² above
        // 10⁻¹² σ_max² (certified by the block inverse when it can be).
        let certified = self.blocks.is_some_and(|b| b.r22 > 1e-6);
        let well_conditioned = certified || triangular_condition(&l22, 1e-6, 10.0)?.ratio > 1e-6;
        // 𝓜 L₂₂ = L₃₂, a right-hand triangular solve.
        if well_conditioned && let Some(m) = solve_right_lower(&l22, l32.clone()) {
            return Ok((m, true));
        }
        let g = &l22 * l22.transpose();
        let m = l32 * l22.transpose() * pinv(&g, RankTolerance::Relative(1e-12))?;
        Ok((m, false))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn layout() -> HankelLayout {
        HankelLayout {
            past: 3,
            future: 3,
            nu: 1,
            ny: 2,
        }
    }

    /// A random lower-triangular factor with a positive diagonal.
    fn factor(k: usize, seed: u64, weak_past_outputs: bool) -> DMatrix<f64> {
        let mut s = seed | 1;
        let lay = layout();
        DMatrix::from_fn(k, k, |i, j| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let r = (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            if i > j {
                r
            } else if i == j {
                if weak_past_outputs && lay.yp().contains(&i) && i > lay.yp().start {
                    0.0
                } else {
                    1.0 + r.abs()
                }
            } else {
                0.0
            }
        })
    }

    #[test]
    fn structured_projections_equal_the_general_formulas() {
        let lay = layout();
        for weak in [false, true] {
            let l = factor(lay.yf().end, 7, weak);
            let pr = Projector::new(&l, lay, 0.0).unwrap();
            assert!(pr.structured);
            let rows = |r: std::ops::Range<usize>| l.rows(r.start, r.len()).into_owned();
            let uf = rows(lay.uf());
            let wp = rows(lay.up().start..lay.yp().end);
            let yf = rows(lay.yf());
            let general = oblique_map(&yf, &uf, &wp).unwrap();
            let (fast, triangular) = pr.oblique_map().unwrap();
            assert_eq!(triangular, !weak);
            assert_relative_eq!(&fast * &wp, &general * &wp, epsilon = 1e-10);
            assert_relative_eq!(
                pr.perp_future_inputs(&yf).unwrap(),
                perp(&yf, &uf).unwrap(),
                epsilon = 1e-12
            );
        }
    }

    #[test]
    fn block_certificate_agrees_with_the_rank_test() {
        let lay = layout();
        for seed in [3, 7, 11] {
            let l = factor(lay.yf().end, seed, false);
            let pr = Projector::new(&l, lay, 0.0).unwrap();
            let r = lay.up().end;
            let luu = l.view((0, 0), (r, r)).into_owned();
            assert_eq!(
                pr.input_rank(1e-10).unwrap(),
                crate::numerics::numerical_rank(&luu, 1e-10).unwrap()
            );
        }
        // A singular input block: the certificate does not claim full rank.
        let mut l = factor(lay.yf().end, 5, false);
        l[(1, 1)] = 0.0;
        let pr = Projector::new(&l, lay, 0.0).unwrap();
        assert!(pr.input_rank(1e-10).unwrap() < lay.up().end);
    }

    #[test]
    fn a_full_factor_takes_the_general_route() {
        let lay = layout();
        let mut l = factor(lay.yf().end, 3, false);
        l[(0, 5)] = 0.25;
        let pr = Projector::new(&l, lay, 0.0).unwrap();
        assert!(!pr.structured);
        let uf = l.rows(0, lay.uf().end).into_owned();
        let m = DMatrix::from_fn(2, l.ncols(), |i, j| (i + 2 * j) as f64);
        assert_relative_eq!(
            pr.perp_future_inputs(&m).unwrap(),
            perp(&m, &uf).unwrap(),
            epsilon = 1e-12
        );
    }

    /// σ_min/σ_max of a matrix by its singular values.
    fn sigma_ratio(m: &DMatrix<f64>) -> f64 {
        let s = m.singular_values();
        s.min() / s.max()
    }

    #[test]
    fn the_factors_certificate_bounds_every_diagonal_block() {
        // G = L Lᵀ with λ_min/λ_max certified by the correlation route's
        // test (the shifted factorisation), on factors from well to poorly
        // conditioned: every diagonal block's σ ratio is at least the
        // floor, and the floor is 0 where nothing is certified.
        let lay = layout();
        let k = lay.yf().end;
        let mut outcomes = Vec::new();
        for (seed, weak_diagonal) in [(3, 1.0), (7, 0.05), (11, 1e-5)] {
            // Small off-diagonal entries and one weak pivot in the W_p
            // block: the pivot sets the conditioning (a random triangular
            // factor's σ_min is exponentially small in k).
            let mut l = factor(k, seed, false).map(|v| if v.abs() < 0.5 { 0.05 * v } else { v });
            let weak = lay.yp().start;
            l[(weak, weak)] *= weak_diagonal;
            let g = &l * l.transpose();
            let (_, proven) =
                lifted_linalg::cholesky_condition(g.clone(), crate::CORRELATION_RCOND_MIN)
                    .unwrap()
                    .unwrap();
            let certified = if proven {
                crate::CORRELATION_RCOND_MIN
            } else {
                0.0
            };
            let floor = block_ratio_floor(certified, k);
            assert_eq!(floor > 0.0, proven);
            outcomes.push(proven);
            let e = g.symmetric_eigenvalues();
            assert!(!proven || e.min() / e.max() > crate::CORRELATION_RCOND_MIN);
            for (a, b) in [
                (0, lay.up().end),
                (lay.uf().end, lay.yf().start),
                (0, k),
                (4, 9),
            ] {
                let block = l.view((a, a), (b - a, b - a)).into_owned();
                assert!(sigma_ratio(&block) >= floor, "block {a}..{b}, seed {seed}");
            }
        }
        assert_eq!(outcomes, [true, true, false]);
        assert_eq!(block_ratio_floor(0.0, 160), 0.0);
        assert_eq!(block_ratio_floor(f64::NAN, 160), 0.0);
        // √(10⁻⁸ − 4·160²u) = 10⁻⁴ (1 − 0.12 %).
        assert!((block_ratio_floor(1e-8, 160) - 1e-4).abs() < 2e-7);
    }

    #[test]
    fn a_certified_factor_projects_as_the_inverted_blocks_decide() {
        // The same decisions and the same map with the certificate as with
        // the two block inverses.
        let lay = layout();
        for seed in [3, 7, 11] {
            let l = factor(lay.yf().end, seed, false);
            let plain = Projector::new(&l, lay, 0.0).unwrap();
            let cert = Projector::new(&l, lay, crate::CORRELATION_RCOND_MIN).unwrap();
            assert!(cert.blocks.is_some_and(|b| b.uu > 1e-5 && b.r22 > 1e-5));
            assert_eq!(
                cert.input_rank(1e-10).unwrap(),
                plain.input_rank(1e-10).unwrap()
            );
            assert_eq!(cert.oblique_map().unwrap(), plain.oblique_map().unwrap());
        }
    }
}

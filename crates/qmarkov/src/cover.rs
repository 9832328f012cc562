//! Steps 3–6 of the algorithm (Zhu 2000 §III.C, spec A1.4): from the correlation
//! data `R_yy(τ)`, `H_τ` and `W(τ)` to the realisation `(Â, D̂, Ĉ, Ĥ)`.

use lifted_linalg::{RankTolerance, SortOrder, null_space, pinv, rank, spectral_radius, sym_eig};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::options::WeightingStructure;

/// The data matrices of the cover: `q` output covariances `R_yy(τ)`, `q` Markov
/// parameters `H_τ` and the diagonal input weighting blocks `W(τ)` (eq. III-13).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CoverData {
    /// `R_yy(τ) = (1/2m) Σ_l Σ_k y^l(k+τ) y^l(k)ᵀ`, τ = 0…q−1 (n_y × n_y, eq. III-22).
    pub ryy: Vec<DMatrix<f64>>,
    /// `H_τ`, τ = 0…q−1 (n_y × n_w, eq. III-23 or the hold-deconvolution of A1.4).
    pub markov: Vec<DMatrix<f64>>,
    /// Diagonals of `W(τ)`, τ = 0…q−1 (n_w entries each; zero for τ ≥ n_r).
    pub weighting: Vec<DVector<f64>>,
}

/// Settings of [`realize`] (a subset of [`QMarkovOptions`](crate::QMarkovOptions)).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CoverSettings {
    /// Order `r`; `None` takes the largest eigenvalue gap (up to `max_auto_order`).
    pub order: Option<usize>,
    /// Upper bound of the automatic order.
    pub max_auto_order: usize,
    /// Output weighting `Q` (`None`: identity).
    pub output_weighting: Option<DMatrix<f64>>,
    /// Structure of `W_q`.
    pub weighting: WeightingStructure,
    /// Relative zero threshold for the eigenvalues of `D_q`.
    pub eigen_tol: f64,
    /// Relative singular-value threshold for `P`.
    pub rank_tol: f64,
    /// Orthogonal `U` of eq. (III-29).
    pub rotation: Option<DMatrix<f64>>,
    /// When Â = P⁺P̄ has an eigenvalue on or outside the unit circle,
    /// re-estimate it by the zero-padded shift Â = P_q⁺ [P̄; 0] (Maciejowski's
    /// stabilised shift invariance: its eigenvalues lie inside the unit
    /// circle). The cover then no longer matches the q Markov and covariance
    /// parameters exactly: a stable model is offered instead of none.
    pub enforce_stability: bool,
}

/// Whether `D_q` passed the q-identifiability test of Lemma III-1.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum CoverKind {
    /// `D_q ≥ 0` (within `eigen_tol`): the data are q-identifiable and the cover
    /// matches them.
    Exact,
    /// `D_q` has negative eigenvalues below `−eigen_tol·λ₁`: the data are not
    /// q-identifiable (Lemma III-1). The cover is the least-squares one: `D_q` is
    /// replaced by its nearest positive semidefinite rank-r matrix (negative
    /// eigenvalues dropped, never square-rooted) and `[Â D̂]` solves (III-20) in
    /// least squares.
    LeastSquares,
}

/// The realisation of steps 4–6 and what was decided on the way.
#[derive(Debug, Clone, PartialEq)]
pub struct Realization {
    /// Â (r × r).
    pub a: DMatrix<f64>,
    /// D̂ of the paper, our input matrix B (r × n_w).
    pub b: DMatrix<f64>,
    /// Ĉ = Q⁻¹ P₀ (n_y × r).
    pub c: DMatrix<f64>,
    /// Ĥ = H₀ (n_y × n_w).
    pub d: DMatrix<f64>,
    /// All eigenvalues of `D_q`, descending (the order-selection plot, Fig. 6).
    pub eigenvalues: Vec<f64>,
    /// The order used.
    pub order: usize,
    /// Largest-gap order suggestion.
    pub suggested_order: usize,
    /// Numerical rank of `D_q`.
    pub rank_dq: usize,
    /// Numerical rank of `P` (r when full rank).
    pub rank_p: usize,
    /// Exact or least-squares cover.
    pub cover: CoverKind,
    /// Smallest eigenvalue of `D_q`.
    pub min_eigenvalue: f64,
    /// Number of eigenvalues below `−eigen_tol·λ₁`.
    pub negative_eigenvalues: usize,
    /// Spectral radius of Â = P⁺P̄ when it was replaced by the stabilised
    /// estimate (`enforce_stability`); `None` when Â is the cover's own.
    pub stabilized_from: Option<f64>,
}

/// Checks that the matrix `m` (`what`; `symbol` in a non-finite error) is
/// `rows`×`cols` and finite.
fn check_block(
    what: &'static str,
    symbol: &'static str,
    m: &DMatrix<f64>,
    rows: usize,
    cols: usize,
) -> Result<()> {
    if m.shape() != (rows, cols) {
        return Err(Error::DimensionMismatch {
            what,
            expected: format!("{rows}x{cols}"),
            got: format!("{}x{}", m.nrows(), m.ncols()),
        });
    }
    lifted_linalg::check_finite(symbol, m)?;
    Ok(())
}

/// Checks that `Q` is symmetric positive definite and returns its inverse.
fn check_weighting(q: &DMatrix<f64>, ny: usize) -> Result<DMatrix<f64>> {
    check_block("output weighting Q", "Q", q, ny, ny)?;
    let asym = (q - q.transpose()).amax();
    if asym > 1e-12 * q.amax().max(1.0) {
        return Err(Error::InvalidWeighting {
            reason: format!("not symmetric (max |Q - Qᵀ| = {asym:.3e})"),
        });
    }
    let e = sym_eig(q, SortOrder::Ascending)?;
    let lmin = e.values.iter().copied().fold(f64::INFINITY, f64::min);
    if lmin <= 0.0 {
        return Err(Error::InvalidWeighting {
            reason: format!("smallest eigenvalue {lmin:.3e} is not positive"),
        });
    }
    Ok(lifted_linalg::inv(q)?)
}

/// Largest log-gap order: argmax over `i = 1…k−1` of `ln(λ_i / λ_{i+1})`, with the
/// eigenvalues floored at `floor > 0` (so a numerically exact rank gives an
/// infinite-looking gap at the rank). Ties go to the smaller order.
pub fn largest_gap_order(eigenvalues: &[f64], floor: f64, max_order: usize) -> usize {
    let k = eigenvalues.len().min(max_order + 1);
    let mut best = (1usize, f64::NEG_INFINITY);
    for i in 1..k {
        let hi = eigenvalues[i - 1].max(floor);
        let lo = eigenvalues[i].max(floor);
        let gap = (hi / lo).ln();
        if gap > best.1 {
            best = (i, gap);
        }
    }
    best.0
}

/// Lower block-Toeplitz `H_q` (eq. III-7): block (i, j) = `H_{i−j}` for i ≥ j.
fn block_toeplitz_lower(h: &[DMatrix<f64>], ny: usize, nw: usize) -> DMatrix<f64> {
    let q = h.len();
    let mut out = DMatrix::zeros(q * ny, q * nw);
    for i in 0..q {
        for j in 0..=i {
            out.view_mut((i * ny, j * nw), (ny, nw))
                .copy_from(&h[i - j]);
        }
    }
    out
}

/// Steps 3–6 of §III.C (spec A1.4) on given data matrices.
///
/// `R_q` (block (i,j) = `R_yy(i−j)` for i ≥ j, `R_yy(j−i)ᵀ` otherwise, erratum Z-6),
/// `H_q`, `W_q` (full block-Toeplitz, Z-7, or block-diagonal), `Q_q = I_q ⊗ Q`;
/// `D_q = Q_q (R_q − H_q W_q H_qᵀ) Q_qᵀ` symmetrised, eigen-decomposed in
/// descending order (III-25); `P_q = V_r Λ_r^{1/2}` (III-26); `P`, `P̄` (III-27);
/// `Â = P⁺P̄`, `D̂ = P⁺M_q` with `M_q = (I_{q−1} ⊗ Q)[H_1; …; H_{q−1}]`, plus
/// `V_b U V_dᵀ [I_r; 0]` and `V_b U V_dᵀ [0; I_{n_w}]` when `P` is rank deficient
/// (III-28 – III-30, errata Z-9, Z-10); `Ĉ = Q⁻¹P₀`, `Ĥ = H₀`.
///
/// Cost: O((q n_y)² q n_w) to form `H_q W_q H_qᵀ`, O((q n_y)³) for the symmetric
/// eigen-decomposition, O(q n_y r²) for `P⁺`.
///
/// # Errors
/// [`Error::DimensionMismatch`] for inconsistent blocks, [`Error::InvalidWeighting`],
/// [`Error::NoPositiveEigenvalue`], [`Error::OrderExceedsRank`],
/// [`Error::InvalidOption`] (rotation not orthogonal or of the wrong size), and
/// linear-algebra failures.
pub fn realize(data: &CoverData, settings: &CoverSettings) -> Result<Realization> {
    let q = data.ryy.len();
    if q < 2 {
        return Err(Error::LagsOutOfRange {
            q,
            max_exclusive: usize::MAX,
        });
    }
    if data.markov.len() != q || data.weighting.len() != q {
        return Err(Error::DimensionMismatch {
            what: "cover data",
            expected: format!("{q} Markov parameters and {q} weighting blocks"),
            got: format!("{} and {}", data.markov.len(), data.weighting.len()),
        });
    }
    let ny = data.ryy[0].nrows();
    let nw = data.markov[0].ncols();
    for r in &data.ryy {
        check_block("R_yy block", "R_yy", r, ny, ny)?;
    }
    for h in &data.markov {
        check_block("Markov parameter", "H", h, ny, nw)?;
    }
    for w in &data.weighting {
        if w.len() != nw {
            return Err(Error::DimensionMismatch {
                what: "W(τ) diagonal",
                expected: format!("{nw}"),
                got: format!("{}", w.len()),
            });
        }
    }
    let qw = settings
        .output_weighting
        .clone()
        .unwrap_or_else(|| DMatrix::identity(ny, ny));
    let qinv = check_weighting(&qw, ny)?;

    // Step 3: R_q, H_q, W_q, Q_q.
    let n = q * ny;
    let mut rq = DMatrix::zeros(n, n);
    for i in 0..q {
        for j in 0..q {
            let blk = if i >= j {
                data.ryy[i - j].clone()
            } else {
                data.ryy[j - i].transpose()
            };
            rq.view_mut((i * ny, j * ny), (ny, ny)).copy_from(&blk);
        }
    }
    let hq = block_toeplitz_lower(&data.markov, ny, nw);
    let mut wq = DMatrix::zeros(q * nw, q * nw);
    for i in 0..q {
        for j in 0..q {
            let tau = i.abs_diff(j);
            if tau > 0 && settings.weighting == WeightingStructure::BlockDiagonal {
                continue;
            }
            for l in 0..nw {
                wq[(i * nw + l, j * nw + l)] = data.weighting[tau][l];
            }
        }
    }
    let mut core = rq - &hq * wq * hq.transpose();
    // Q_q (.) Q_qᵀ, block by block.
    if settings.output_weighting.is_some() {
        let mut weighted = DMatrix::zeros(n, n);
        for i in 0..q {
            for j in 0..q {
                let blk = &qw * core.view((i * ny, j * ny), (ny, ny)) * qw.transpose();
                weighted
                    .view_mut((i * ny, j * ny), (ny, ny))
                    .copy_from(&blk);
            }
        }
        core = weighted;
    }

    // Step 4: ordered symmetric eigen-decomposition (III-25).
    let eig = sym_eig(&core, SortOrder::Descending)?;
    let lambda: Vec<f64> = eig.values.iter().copied().collect();
    let l1 = lambda[0];
    if l1.is_nan() || l1 <= 0.0 {
        return Err(Error::NoPositiveEigenvalue { largest: l1 });
    }
    let zero = settings.eigen_tol * l1;
    let rank_dq = lambda.iter().filter(|&&v| v > zero).count();
    let negative = lambda.iter().filter(|&&v| v < -zero).count();
    let min_eigenvalue = lambda[lambda.len() - 1];
    let cover = if negative == 0 {
        CoverKind::Exact
    } else {
        CoverKind::LeastSquares
    };
    let floor = zero.max(f64::MIN_POSITIVE);
    let suggested = largest_gap_order(&lambda, floor, settings.max_auto_order.min(rank_dq));
    let r = settings.order.unwrap_or(suggested);
    if r == 0 {
        return Err(Error::InvalidOption {
            what: "order",
            reason: "the model order r must be at least 1".into(),
        });
    }
    if r > rank_dq {
        return Err(Error::OrderExceedsRank {
            order: r,
            rank: rank_dq,
        });
    }
    // P_q = V_r Λ_r^{1/2}: only eigenvalues > eigen_tol·λ₁ > 0 reach the square root.
    let mut pq = eig.vectors.columns(0, r).into_owned();
    for (k, mut col) in pq.column_iter_mut().enumerate() {
        col *= lambda[k].sqrt();
    }

    // Step 5: P, P̄ (III-27), M_q.
    let p = pq.rows(0, n - ny).into_owned();
    let pbar = pq.rows(ny, n - ny).into_owned();
    let mut mq = DMatrix::zeros(n - ny, nw);
    for i in 1..q {
        mq.view_mut(((i - 1) * ny, 0), (ny, nw))
            .copy_from(&(&qw * &data.markov[i]));
    }

    // Step 6: Â = P⁺P̄, D̂ = P⁺M_q (+ V_b U V_dᵀ I₁,₂ if P is rank deficient).
    let tol = RankTolerance::Relative(settings.rank_tol);
    let pp = pinv(&p, tol)?;
    let mut a = &pp * &pbar;
    let mut b = &pp * &mq;
    let rank_p = rank(&p, tol)?;
    if rank_p < r {
        let vb = null_space(&p, tol)?;
        let mut pm = DMatrix::zeros(n - ny, r + nw);
        pm.columns_mut(0, r).copy_from(&pbar);
        pm.columns_mut(r, nw).copy_from(&mq);
        let vd = null_space(&pm, tol)?;
        let k = vb.ncols().min(vd.ncols());
        if k > 0 {
            let u = match &settings.rotation {
                None => DMatrix::identity(k, k),
                Some(u) => {
                    if u.shape() != (k, k) {
                        return Err(Error::InvalidOption {
                            what: "rotation",
                            reason: format!("U must be {k}x{k}, got {}x{}", u.nrows(), u.ncols()),
                        });
                    }
                    let dev = (u.transpose() * u - DMatrix::<f64>::identity(k, k)).amax();
                    if dev.is_nan() || dev >= 1e-8 {
                        return Err(Error::InvalidOption {
                            what: "rotation",
                            reason: format!("U is not orthogonal (max |UᵀU − I| = {dev:.3e})"),
                        });
                    }
                    u.clone()
                }
            };
            let corr = vb.columns(0, k) * u * vd.columns(0, k).transpose();
            a += corr.columns(0, r);
            b += corr.columns(r, nw);
        }
    }
    let mut stabilized_from = None;
    if settings.enforce_stability {
        let rho = spectral_radius(&a)?;
        if rho >= 1.0 {
            let mut padded = DMatrix::zeros(n, r);
            padded.rows_mut(0, n - ny).copy_from(&pbar);
            a = pinv(&pq, tol)? * padded;
            stabilized_from = Some(rho);
        }
    }
    let c = &qinv * pq.rows(0, ny);
    let d = data.markov[0].clone();
    Ok(Realization {
        a,
        b,
        c,
        d,
        eigenvalues: lambda,
        order: r,
        suggested_order: suggested,
        rank_dq,
        rank_p,
        cover,
        min_eigenvalue,
        negative_eigenvalues: negative,
        stabilized_from,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gap_order_picks_largest_ratio() {
        assert_eq!(largest_gap_order(&[10.0, 9.0, 0.01, 0.009], 1e-12, 10), 2);
        assert_eq!(largest_gap_order(&[10.0, 0.1, 0.001, 1e-7], 1e-12, 10), 3);
        // Limited to max_order.
        assert_eq!(largest_gap_order(&[10.0, 0.1, 0.001, 1e-7], 1e-12, 2), 1);
        // Exact rank: the floor makes the gap at the rank dominate.
        assert_eq!(largest_gap_order(&[1.0, 0.5, 0.0, -1e-17], 1e-12, 10), 2);
    }

    #[test]
    fn lower_toeplitz_layout() {
        let h: Vec<DMatrix<f64>> = (0..3)
            .map(|i| DMatrix::from_element(1, 1, i as f64 + 1.0))
            .collect();
        let t = block_toeplitz_lower(&h, 1, 1);
        assert_eq!(
            t,
            DMatrix::from_row_slice(3, 3, &[1., 0., 0., 2., 1., 0., 3., 2., 1.])
        );
    }
}

//! Small numerical helpers shared by the engine, the IV methods and the
//! regressions: the exact power-of-4 data scaling, numerical rank, spectral
//! radius, (A, C) from an extended observability matrix.

use lifted_linalg::{lstsq, spectral_radius};
use nalgebra::DMatrix;

use crate::error::Result;

pub(crate) fn rows(m: &DMatrix<f64>, r: std::ops::Range<usize>) -> DMatrix<f64> {
    m.rows(r.start, r.len()).into_owned()
}

pub(crate) fn vstack(parts: &[&DMatrix<f64>]) -> DMatrix<f64> {
    let nr: usize = parts.iter().map(|p| p.nrows()).sum();
    let nc = parts.first().map_or(0, |p| p.ncols());
    let mut out = DMatrix::zeros(nr, nc);
    let mut r = 0;
    for p in parts {
        out.rows_mut(r, p.nrows()).copy_from(p);
        r += p.nrows();
    }
    out
}

/// (A, C) from an extended observability matrix with `ny` rows per block by
/// shift invariance over all block rows (erratum L-3: A = Γ↑⁺ Γ↓), and the
/// stabilised variant A = Γ⁺ [Γ↓; 0] when requested and needed (ρ(A) ≥
/// 1 + `marginal`: an estimate within `marginal` of the unit circle is
/// kept, its poles taken as integrators).
pub(crate) fn ac_from_gamma(
    gamma: &DMatrix<f64>,
    ny: usize,
    enforce_stability: bool,
    marginal: f64,
) -> Result<(DMatrix<f64>, DMatrix<f64>, bool)> {
    let (rows_g, n) = gamma.shape();
    let up = gamma.rows(0, rows_g - ny).into_owned();
    let dn = gamma.rows(ny, rows_g - ny).into_owned();
    let mut a = lstsq(&up, &dn)?;
    let c = gamma.rows(0, ny).into_owned();
    let mut stabilized = false;
    if enforce_stability && spectral_radius(&a)? >= 1.0 + marginal {
        let mut padded = DMatrix::zeros(rows_g, n);
        padded.rows_mut(0, rows_g - ny).copy_from(&dn);
        a = lstsq(gamma, &padded)?;
        stabilized = true;
    }
    Ok((a, c, stabilized))
}

/// Γ = U₁ S₁^{1/2}: the first `n` columns of `u` scaled by the square roots
/// of the singular values `s`.
pub(crate) fn scaled_basis(u: &DMatrix<f64>, s: &[f64], n: usize) -> DMatrix<f64> {
    let mut gamma = u.columns(0, n).into_owned();
    for (j, sv) in s.iter().take(n).enumerate() {
        gamma.column_mut(j).scale_mut(sv.sqrt());
    }
    gamma
}

/// Numerical rank of a lower-triangular Gram factor block.
pub(crate) fn numerical_rank(m: &DMatrix<f64>, rel: f64) -> Result<usize> {
    let k = m.nrows();
    let lower = m.ncols() == k && (0..k).all(|j| (0..j).all(|i| m[(i, j)] == 0.0));
    if lower && k > 0 {
        // Full rank shown by the O(k²) estimates (clear of `rel` by 10×);
        // otherwise the singular values count.
        let check = lifted_linalg::triangular_condition(m, rel, 10.0)?;
        if check.ratio > rel {
            return Ok(k);
        }
    }
    let s = lifted_linalg::singular_values(m)?;
    let smax = s.iter().cloned().fold(0.0, f64::max);
    Ok(s.iter().filter(|&&v| smax > 0.0 && v > rel * smax).count())
}

/// Scalars (powers of 4) by which the inputs, outputs and instruments are
/// divided before the identification. The subspace methods are equivariant
/// under such scalings (the projections see row spaces; the weighted
/// singular values scale with the outputs), but their relative rank
/// tolerances and the squared data products are not: without it, outputs
/// 1e-7 times smaller than the inputs changed the N4SID poles and data of
/// magnitude 1e150 overflowed the Gram matrices. Powers of 4 keep the
/// scaling, its square root and its undoing exact.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub(crate) struct Scale {
    /// Input scale s_u.
    pub u: f64,
    /// Output scale s_y.
    pub y: f64,
}

impl Scale {
    /// No scaling.
    pub(crate) const ONE: Scale = Scale { u: 1.0, y: 1.0 };

    /// Model matrices of the scaled data (B̃, C̃, D̃) in original units:
    /// B = B̃/s_u, C = s_y C̃, D = s_y D̃/s_u (A and the state unchanged).
    pub(crate) fn unscale(
        &self,
        b: DMatrix<f64>,
        c: DMatrix<f64>,
        d: DMatrix<f64>,
    ) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
        (b / self.u, c * self.y, d * (self.y / self.u))
    }

    /// The inverse of [`Scale::unscale`].
    pub(crate) fn rescale(
        &self,
        b: &DMatrix<f64>,
        c: &DMatrix<f64>,
        d: &DMatrix<f64>,
    ) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
        (b * self.u, c / self.y, d * (self.u / self.y))
    }
}

/// The power of 4 nearest (in ratio) to the RMS of the finite entries of
/// `mats`; 1 when they are all zero. One pass with eight independent lanes
/// (vectorised), and a second pass with the entries divided by the largest
/// one only when the squares could overflow or underflow. O(entries).
pub(crate) fn pow4_scale(mats: &[&DMatrix<f64>]) -> f64 {
    pow4_scale_counted(mats).0
}

/// [`pow4_scale`] and the number of finite entries it saw.
pub(crate) fn pow4_scale_counted(mats: &[&DMatrix<f64>]) -> (f64, usize) {
    lifted_linalg::simd::dispatch(
        #[inline(always)]
        || {
            // Eight independent lanes (sum, largest magnitude, count): no chain of
            // dependent max/add across elements, so the loop vectorises.
            const LANES: usize = 8;
            let mut sums = [0.0f64; LANES];
            let mut bigs = [0.0f64; LANES];
            let mut counts = [0usize; LANES];
            for m in mats {
                let v = m.as_slice();
                let mut chunks = v.chunks_exact(LANES);
                for c in &mut chunks {
                    for l in 0..LANES {
                        let x = c[l];
                        let ok = x.is_finite();
                        let x = if ok { x } else { 0.0 };
                        bigs[l] = bigs[l].max(x.abs());
                        sums[l] += x * x;
                        counts[l] += usize::from(ok);
                    }
                }
                for &x in chunks.remainder() {
                    if x.is_finite() {
                        bigs[0] = bigs[0].max(x.abs());
                        sums[0] += x * x;
                        counts[0] += 1;
                    }
                }
            }
            let big = bigs.iter().cloned().fold(0.0f64, f64::max);
            let count: usize = counts.iter().sum();
            if big <= 0.0 {
                return (1.0, count);
            }
            let mut sum: f64 = sums.iter().sum();
            let mut unit = 1.0;
            if !(1e-150..=1e150).contains(&big) || !sum.is_finite() {
                // Squares out of range: the same sums of (v / big)².
                sum = mats
                    .iter()
                    .flat_map(|m| m.iter())
                    .filter(|v| v.is_finite())
                    .map(|v| (v / big) * (v / big))
                    .sum();
                unit = big;
            }
            let rms = unit * (sum / count as f64).sqrt();
            let k = (rms.log2() / 2.0).round().clamp(-500.0, 500.0) as i32;
            (2f64.powi(2 * k), count)
        },
    )
}

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
    let parts: Vec<(&[f64], f64)> = mats.iter().map(|m| (m.as_slice(), 0.0)).collect();
    pow4_of_parts(&parts)
}

/// The scale a stream's first block fixes ([`pow4_scale`] of the block's
/// columns less their means when `centre`, as the whole-record route
/// scales the centred records), and the column means (zeros without
/// centring). No copy of the block: one vectorised sum per column, then
/// the centred squares in the same pass as [`pow4_scale`]'s. O(entries).
pub(crate) fn first_block_scale(m: &DMatrix<f64>, centre: bool) -> (f64, Vec<f64>) {
    let rows = m.nrows();
    let columns: Vec<&[f64]> = if rows == 0 {
        Vec::new()
    } else {
        m.as_slice().chunks_exact(rows).collect()
    };
    let means: Vec<f64> = columns
        .iter()
        .map(|c| {
            if centre {
                lifted_linalg::kernels::sum(c) / rows as f64
            } else {
                0.0
            }
        })
        .collect();
    let parts: Vec<(&[f64], f64)> = columns.into_iter().zip(means.iter().copied()).collect();
    (pow4_of_parts(&parts).0, means)
}

/// What a stream's first block (u, y) fixes: the [`Scale`] of its inputs and
/// outputs ([`first_block_scale`]) and the centring reference, the
/// channels' means in the scaled units (inputs then outputs; exact: the
/// scales are powers of 4; zeros without centring). O(entries).
pub(crate) fn first_block_centring(
    u: &DMatrix<f64>,
    y: &DMatrix<f64>,
    centre: bool,
) -> (Scale, Vec<f64>) {
    let (su, mu) = first_block_scale(u, centre);
    let (sy, my) = first_block_scale(y, centre);
    let reference = mu
        .iter()
        .map(|m| m / su)
        .chain(my.iter().map(|m| m / sy))
        .collect();
    (Scale { u: su, y: sy }, reference)
}

/// [`pow4_scale_counted`] of the entries `x − offset` of each part.
fn pow4_of_parts(parts: &[(&[f64], f64)]) -> (f64, usize) {
    lifted_linalg::simd::dispatch(
        #[inline(always)]
        || {
            // Eight independent lanes (sum, largest magnitude, count): no chain of
            // dependent max/add across elements, and comparisons and selects
            // (not `f64::max`, whose NaN rule costs a blend) so the loop
            // vectorises. Non-finite entries count as zero and are not counted.
            const LANES: usize = 8;
            let mut sums = [0.0f64; LANES];
            let mut bigs = [0.0f64; LANES];
            let mut counts = [0u64; LANES];
            for &(v, off) in parts {
                let mut chunks = v.chunks_exact(LANES);
                for c in &mut chunks {
                    for l in 0..LANES {
                        let a = (c[l] - off).abs();
                        let ok = a < f64::INFINITY;
                        let a = if ok { a } else { 0.0 };
                        bigs[l] = if a > bigs[l] { a } else { bigs[l] };
                        sums[l] += a * a;
                        counts[l] += u64::from(ok);
                    }
                }
                for &x in chunks.remainder() {
                    let a = (x - off).abs();
                    if a < f64::INFINITY {
                        bigs[0] = bigs[0].max(a);
                        sums[0] += a * a;
                        counts[0] += 1;
                    }
                }
            }
            let big = bigs.iter().cloned().fold(0.0f64, f64::max);
            let count = counts.iter().sum::<u64>() as usize;
            if big <= 0.0 {
                return (1.0, count);
            }
            let mut sum: f64 = sums.iter().sum();
            let mut unit = 1.0;
            if !(1e-150..=1e150).contains(&big) || !sum.is_finite() {
                // Squares out of range: the same sums of (v / big)².
                sum = parts
                    .iter()
                    .flat_map(|&(v, off)| v.iter().map(move |x| x - off))
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

#[cfg(test)]
mod tests {
    use super::{first_block_scale, pow4_scale};
    use nalgebra::DMatrix;

    /// The first block's scale and means without a copy agree with the
    /// centred copy's [`pow4_scale`] and nalgebra's column means (to
    /// rounding: the sums run in another order), and without centring
    /// with [`pow4_scale`] of the block itself, for block lengths that
    /// leave remainders of the eight lanes.
    #[test]
    fn the_first_block_scale_is_that_of_the_centred_block() {
        for rows in [1usize, 7, 8, 13, 1000] {
            let m = DMatrix::from_fn(rows, 3, |i, j| {
                let x = ((i * 7919 + j * 104_729) % 1013) as f64 / 1013.0;
                [5.0e3, -2.0, 1.0e-6][j] + [3.0e2, 0.7, 2.0e-7][j] * x
            });
            let (scale, means) = first_block_scale(&m, true);
            let mut centred = m.clone();
            for (j, mut col) in centred.column_iter_mut().enumerate() {
                let mean = col.mean();
                assert!((means[j] - mean).abs() <= 1e-14 * mean.abs(), "rows {rows}");
                col.add_scalar_mut(-mean);
            }
            assert_eq!(scale, pow4_scale(&[&centred]), "rows {rows}");
            let (raw, zeros) = first_block_scale(&m, false);
            assert_eq!(raw, pow4_scale(&[&m]), "rows {rows}");
            assert!(zeros.iter().all(|&z| z == 0.0));
        }
        // Non-finite entries are left out of the scale, as pow4_scale does.
        let m = DMatrix::from_column_slice(4, 1, &[1.0, f64::NAN, 4.0, 16.0]);
        assert_eq!(first_block_scale(&m, false).0, pow4_scale(&[&m]));
    }
}

//! The modal filters of all inputs advanced together in AVX2 lanes: one
//! sample of every filter is a few vector operations instead of a loop
//! over the inputs and modes.
//!
//! Each input's n filters take 4·⌈n/4⌉ lanes, the complex pairs first (a
//! pair in two adjacent lanes, the first even), then the real modes, the
//! rest zero. With the lanes' coefficients α, β, e a sample is
//!
//! w ← α ⊙ w + (β ⊙ swap(w) + e · u_j(t))
//!
//! (swap exchanges the two lanes of each pair): for a real mode α = λ,
//! β = 0, e = 1; for a pair's real part α = a, β = −b, e = 1 and its
//! imaginary part α = a, β = b, e = 0 — with fused multiply-adds the
//! operations of [`ModalForm::step`](super::ModalForm), so the values are
//! the scalar recursion's to the bit (a product with a zero coefficient
//! adds an exact zero; only the sign of a zero result can differ). The
//! recursion is serial in time; its chain per sample is one shuffle and
//! two fused multiply-adds, the vectors of the inputs in flight together.
//! Written filter values go time-major to a small buffer and are then
//! copied column by column into the base rows' block. O(⌈n/4⌉ n_u) vector
//! operations per sample.

use super::Mode;

/// Most vectors of four lanes (filters of all inputs) of the vector path;
/// more take the scalar loop.
pub(super) const MAX_VECTORS: usize = 8;

/// Samples per chunk of the time-major buffer (≤ 32 KiB at
/// [`MAX_VECTORS`]: in L1 until copied out).
const CHUNK: usize = 128;

/// The lanes' layout and coefficients for a mode list and input count.
#[derive(Debug, Clone)]
pub(super) struct Lanes {
    /// Input of each vector.
    input: Vec<usize>,
    alpha: Vec<[f64; 4]>,
    beta: Vec<[f64; 4]>,
    e: Vec<[f64; 4]>,
    /// Lane (vector · 4 + lane) of filter c = j·n + i.
    lane: Vec<usize>,
}

impl Lanes {
    /// The layout for `modes` (n states) and `nu` inputs; `None` beyond
    /// [`MAX_VECTORS`] vectors or without inputs.
    pub(super) fn of(modes: &[Mode], nu: usize) -> Option<Self> {
        let n: usize = modes
            .iter()
            .map(|m| if matches!(m, Mode::Real(_)) { 1 } else { 2 })
            .sum();
        let per = n.div_ceil(4);
        let vectors = per * nu;
        if nu == 0 || n == 0 || vectors > MAX_VECTORS {
            return None;
        }
        // Slots of one input's states: pairs first, then reals.
        let mut slot = vec![0usize; n];
        let (mut coef_a, mut coef_b, mut coef_e) =
            (vec![0.0; 4 * per], vec![0.0; 4 * per], vec![0.0; 4 * per]);
        let mut next = 0;
        let mut i = 0;
        for m in modes {
            match *m {
                Mode::Pair(a, b) => {
                    slot[i] = next;
                    slot[i + 1] = next + 1;
                    (coef_a[next], coef_b[next], coef_e[next]) = (a, -b, 1.0);
                    (coef_a[next + 1], coef_b[next + 1], coef_e[next + 1]) = (a, b, 0.0);
                    next += 2;
                    i += 2;
                }
                Mode::Real(_) => i += 1,
            }
        }
        let mut i = 0;
        for m in modes {
            match *m {
                Mode::Real(l) => {
                    slot[i] = next;
                    (coef_a[next], coef_b[next], coef_e[next]) = (l, 0.0, 1.0);
                    next += 1;
                    i += 1;
                }
                Mode::Pair(..) => i += 2,
            }
        }
        let four = |c: &[f64], k: usize| [c[4 * k], c[4 * k + 1], c[4 * k + 2], c[4 * k + 3]];
        let mut lanes = Lanes {
            input: Vec::with_capacity(vectors),
            alpha: Vec::with_capacity(vectors),
            beta: Vec::with_capacity(vectors),
            e: Vec::with_capacity(vectors),
            lane: Vec::with_capacity(n * nu),
        };
        for j in 0..nu {
            for k in 0..per {
                lanes.input.push(j);
                lanes.alpha.push(four(&coef_a, k));
                lanes.beta.push(four(&coef_b, k));
                lanes.e.push(four(&coef_e, k));
            }
            lanes.lane.extend(slot.iter().map(|&s| 4 * per * j + s));
        }
        Some(lanes)
    }

    /// Vectors of four lanes.
    pub(super) fn vectors(&self) -> usize {
        self.input.len()
    }

    /// Runs the filters `w` (n per input, the scalar layout) over the
    /// instants `ts` of `u` (each sample times `iu`), writing the values
    /// before each instant as [`ModalForm::run`](super::ModalForm) does
    /// (`out = (block, stride, row)`). The token proves AVX2 and FMA.
    pub(super) fn run(
        &self,
        simd: lifted_linalg::simd::Avx2Fma,
        w: &mut [f64],
        u: &nalgebra::DMatrix<f64>,
        iu: f64,
        ts: std::ops::Range<usize>,
        out: Option<(&mut [f64], usize, usize)>,
    ) {
        macro_rules! with {
            ($($v:literal)*) => {
                match self.vectors() {
                    $($v => self.run_v::<$v>(simd, w, u, iu, ts, out),)*
                    _ => unreachable!("at most MAX_VECTORS vectors (Lanes::of)"),
                }
            };
        }
        with!(1 2 3 4 5 6 7 8)
    }

    /// [`run`](Self::run) with `V` vectors held in registers.
    fn run_v<const V: usize>(
        &self,
        simd: lifted_linalg::simd::Avx2Fma,
        w: &mut [f64],
        u: &nalgebra::DMatrix<f64>,
        iu: f64,
        ts: std::ops::Range<usize>,
        out: Option<(&mut [f64], usize, usize)>,
    ) {
        let mut state = [[0.0f64; 4]; V];
        for (c, &l) in self.lane.iter().enumerate() {
            state[l / 4][l % 4] = w[c];
        }
        let rows = u.nrows();
        let us = u.as_slice();
        let cols: [usize; V] = std::array::from_fn(|v| self.input[v] * rows);
        let mut buf = vec![0.0f64; if out.is_some() { CHUNK * 4 * V } else { 0 }];
        let mut out = out;
        let mut t = ts.start;
        while t < ts.end {
            let len = CHUNK.min(ts.end - t);
            let keep = if out.is_some() {
                Some(&mut buf[..])
            } else {
                None
            };
            step_chunk::<V>(simd, self, &mut state, us, &cols, iu, t..t + len, keep);
            if let Some((blk, stride, row)) = out.as_mut() {
                let k0 = t - ts.start;
                for (c, &l) in self.lane.iter().enumerate() {
                    let at = c * *stride + *row + k0;
                    for (k, o) in blk[at..at + len].iter_mut().enumerate() {
                        *o = buf[k * 4 * V + l];
                    }
                }
            }
            t += len;
        }
        for (c, &l) in self.lane.iter().enumerate() {
            w[c] = state[l / 4][l % 4];
        }
    }
}

/// The filters over the instants `ts` (at most [`CHUNK`]), the values
/// before each instant k written time-major to `keep[k·4V ..]`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn step_chunk<const V: usize>(
    simd: lifted_linalg::simd::Avx2Fma,
    lanes: &Lanes,
    state: &mut [[f64; 4]; V],
    us: &[f64],
    cols: &[usize; V],
    iu: f64,
    ts: std::ops::Range<usize>,
    keep: Option<&mut [f64]>,
) {
    let _ = simd;
    assert!(
        cols.iter().all(|&c| c + ts.end <= us.len())
            && keep.as_ref().is_none_or(|k| k.len() >= ts.len() * 4 * V),
        "modal lanes: ranges checked by the caller"
    );
    #[cfg(target_arch = "x86_64")]
    // SAFETY: `simd` proves AVX2 and FMA; every read of `us` is at
    // cols[v] + t < us.len() and every write of `keep` below
    // ts.len()·4V (asserted above).
    unsafe {
        step_chunk_avx2::<V>(lanes, state, us, cols, iu, ts, keep);
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let mut keep = keep;
        for (k, t) in ts.enumerate() {
            for v in 0..V {
                if let Some(kb) = keep.as_deref_mut() {
                    kb[(k * V + v) * 4..(k * V + v) * 4 + 4].copy_from_slice(&state[v]);
                }
                let x = us[cols[v] + t] * iu;
                let s = state[v];
                let sw = [s[1], s[0], s[3], s[2]];
                for l in 0..4 {
                    let ue = x * lanes.e[v][l];
                    state[v][l] =
                        lanes.alpha[v][l].mul_add(s[l], lanes.beta[v][l].mul_add(sw[l], ue));
                }
            }
        }
    }
}

/// The AVX2 body of [`step_chunk`].
///
/// # Safety
/// AVX2 and FMA must be available; `us[cols[v] + t]` readable for every
/// vector v and t in `ts`, `keep` (when given) writable for ts.len()·4V
/// entries.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn step_chunk_avx2<const V: usize>(
    lanes: &Lanes,
    state: &mut [[f64; 4]; V],
    us: &[f64],
    cols: &[usize; V],
    iu: f64,
    ts: std::ops::Range<usize>,
    keep: Option<&mut [f64]>,
) {
    use std::arch::x86_64::*;
    // SAFETY: the offsets formed are those the caller guarantees.
    unsafe {
        let load = |a: &[f64; 4]| _mm256_loadu_pd(a.as_ptr());
        let alpha: [__m256d; V] = std::array::from_fn(|v| load(&lanes.alpha[v]));
        let beta: [__m256d; V] = std::array::from_fn(|v| load(&lanes.beta[v]));
        let e: [__m256d; V] = std::array::from_fn(|v| load(&lanes.e[v]));
        let mut w: [__m256d; V] = std::array::from_fn(|v| load(&state[v]));
        let p = us.as_ptr();
        let keep = keep.map(|k| k.as_mut_ptr());
        for (k, t) in ts.enumerate() {
            for v in 0..V {
                if let Some(kp) = keep {
                    _mm256_storeu_pd(kp.add((k * V + v) * 4), w[v]);
                }
                let x = _mm256_set1_pd(*p.add(cols[v] + t) * iu);
                let ue = _mm256_mul_pd(x, e[v]);
                let sw = _mm256_permute_pd::<0b0101>(w[v]);
                w[v] = _mm256_fmadd_pd(alpha[v], w[v], _mm256_fmadd_pd(beta[v], sw, ue));
            }
        }
        for v in 0..V {
            _mm256_storeu_pd(state[v].as_mut_ptr(), w[v]);
        }
    }
}

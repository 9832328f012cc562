//! The lagged sums of [`super`] by FFT for long spans:
//! S_ce(δ) += Σ_{t<len} z_c(t) z_e(t + δ), δ < span, in
//! O(n_z log m + n_z² + n_z² span²/l) operations per instant instead of the
//! direct kernel's n_z² span.
//!
//! The instants are cut into blocks of l = m − span + 1 (m a power of two,
//! at least [`BLOCK_PER_SPAN`] · span). For a block b of length l_b, with
//! x_c its samples of channel c zero-padded to m and X_c = FFT(x_c), the
//! circular correlation IFFT(conj(X_c) X_e)[δ] = Σ_t x_c(t) x_e((t + δ) mod m)
//! has no wrapped term for |δ| < span (l_b + span − 1 ≤ m), so it is the
//! sum over the pairs of instants inside the block: at δ for (c, e) and at
//! m − δ for (e, c). The spectra conj(X_c) X_e are summed over the blocks
//! for c ≤ e and transformed back once per call; the pairs that straddle a
//! block's end (t in the block, t + δ past it: δ of them at lag δ) are
//! summed directly. Two channels share one complex transform (real and
//! imaginary parts, separated by the spectrum's symmetry).
//!
//! Cost per instant, n_z = 4 and span = 40 (m = 2048): two complex
//! transforms of m per block (≈ 2 · 5 m log₂ m / l flops), n_z(n_z + 1)/2
//! complex products per frequency (≈ 40 (m/2)/l flops) and n_z² span²/(2l)
//! direct products (≈ 13 flops): about a sixth of the direct kernel's
//! 1 280 flops. Rounding: each block's sums carry the transform's relative
//! error (≈ ε log₂ m of the block's ‖x_c‖ ‖x_e‖), the same order as the
//! direct sums' ε l_b; the sums equal the direct kernel's to rounding, not
//! to the bit. Memory: n_z blocks of l + span − 1 values, the spectra of
//! n_z channels and of n_z(n_z + 1)/2 pairs (m/2 + 1 complex values each).

use lifted_linalg::fft::{Transforms, split_packed};
use num_complex::Complex;

use super::Channel;

/// Blocks of at least this many spans (m ≥ 32 span): the straddling pairs'
/// direct products, n_z² span²/(2l) per instant, stay below a fiftieth of
/// the direct kernel's n_z² span.
const BLOCK_PER_SPAN: usize = 32;

/// Smallest span for which [`fft_sums`] is used (a speed choice only: the
/// sums are the same to rounding either way). Measured 2026-12-02 on a
/// 2-core AMD EPYC with AVX-512 (Zen 4), `peer_lifted --stream --threads 1`
/// on the 1e6-sample 2 × 2 peers record (n_z = 4), compression time direct
/// → FFT: span 10 10.6 → 14.1 ms, span 16 14.2 → 17.9, span 20 16–19 →
/// 16–20 (the crossing, within the machine's noise), span 24 18.9–19.5 →
/// 15.8–16.6, span 32 26.9 → 17.8, span 40 27.4 → 16.5, span 60 41.6 →
/// 21.6 (`benches/results/slicot.md`, session 47).
pub(crate) const FFT_MIN_SPAN: usize = 24;

/// Work space of [`fft_sums`], kept across calls (no allocation from block
/// to block of a stream once the sizes are known).
#[derive(Default)]
pub(crate) struct FftScratch {
    /// The transforms of length m (planned once per length).
    transforms: Option<Transforms>,
    /// One complex block (two channels packed, or a pair's spectrum).
    buf: Vec<Complex<f64>>,
    /// Each channel's samples of one block and the span − 1 after it.
    cols: Vec<Vec<f64>>,
    /// The channels' spectra of one block (n_z × (m/2 + 1)), split.
    xr: Vec<f64>,
    xi: Vec<f64>,
    /// Σ_b conj(X_c) X_e for c ≤ e (pairs × (m/2 + 1)), split.
    pr: Vec<f64>,
    pi: Vec<f64>,
    /// One pair's straddling sums by lag.
    row: Vec<f64>,
}

impl std::fmt::Debug for FftScratch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FftScratch")
            .field("m", &self.transforms.as_ref().map(Transforms::len))
            .finish()
    }
}

/// The transform length for `span`: the power of two ≥ BLOCK_PER_SPAN · span.
pub(crate) fn block_length(span: usize) -> usize {
    (BLOCK_PER_SPAN * span.max(1)).next_power_of_two()
}

/// Fewest instants of a call for which [`fft_sums`] is used: a process's
/// first FFT call plans the transforms and allocates the spectra (0.2 ms
/// more than the direct kernel for the 1e4-sample peers record, 2026-12-02,
/// Zen 4), which the FFT's ≈ 10 ns an instant (span 40) repays only past
/// about 2e4 instants.
pub(crate) const FFT_MIN_LEN: usize = 32_768;

/// Whether [`fft_sums`] is the cheaper way for this call: a span of at
/// least [`FFT_MIN_SPAN`] and at least [`FFT_MIN_LEN`] instants and four
/// blocks (the n_z(n_z + 1)/2 inverse transforms of a call are then a
/// small part).
pub(crate) fn worth_it(span: usize, len: usize) -> bool {
    span >= FFT_MIN_SPAN && len >= FFT_MIN_LEN.max(4 * (block_length(span) - span + 1))
}

/// S[(δ n_z + c) n_z + e] += Σ_{t<len} z_c(t) z_e(t + δ), δ < span (module
/// docs); each channel must have `len + span − 1` samples.
pub(crate) fn fft_sums(
    z: &[Channel<'_>],
    span: usize,
    len: usize,
    s: &mut [f64],
    w: &mut FftScratch,
) {
    let nz = z.len();
    if nz == 0 || span == 0 || len == 0 {
        return;
    }
    let m = block_length(span);
    let l = m - span + 1;
    let h = m / 2 + 1;
    let pairs = nz * (nz + 1) / 2;
    if w.transforms.as_ref().map(Transforms::len) != Some(m) {
        w.transforms = Some(Transforms::new(m));
    }
    w.buf.resize(m, Complex::new(0.0, 0.0));
    w.cols.resize_with(nz, Vec::new);
    for c in &mut w.cols {
        c.resize(l + span - 1, 0.0);
    }
    for v in [&mut w.xr, &mut w.xi] {
        v.resize(nz * h, 0.0);
    }
    for v in [&mut w.pr, &mut w.pi] {
        v.clear();
        v.resize(pairs * h, 0.0);
    }
    let FftScratch {
        transforms,
        buf,
        cols,
        xr,
        xi,
        pr,
        pi,
        row,
    } = w;
    let Some(tr) = transforms.as_mut() else {
        return;
    };
    let mut t0 = 0;
    while t0 < len {
        let lb = l.min(len - t0);
        for (c, col) in z.iter().zip(cols.iter_mut()) {
            c.write(t0, lb + span - 1, col, 1, 0);
        }
        // The channels' spectra, two to a transform.
        let mut c = 0;
        while c < nz {
            let two = c + 1 < nz;
            let (head, tail) = buf.split_at_mut(lb);
            if two {
                for ((b, x), y) in head.iter_mut().zip(&cols[c]).zip(&cols[c + 1]) {
                    *b = Complex::new(*x, *y);
                }
            } else {
                for (b, x) in head.iter_mut().zip(&cols[c]) {
                    *b = Complex::new(*x, 0.0);
                }
            }
            tail.fill(Complex::new(0.0, 0.0));
            // The length is m by construction: the check cannot fail.
            if tr.forward(buf).is_err() {
                return;
            }
            unpack(buf, two, c, h, xr, xi);
            c += 2;
        }
        accumulate(nz, h, xr, xi, pr, pi);
        straddling(cols, nz, span, lb, s, row);
        t0 += lb;
    }
    // Back to lags: one inverse transform per pair c ≤ e.
    let scale = 1.0 / m as f64;
    let mut p = 0;
    for c in 0..nz {
        for e in c..nz {
            let (re, im) = (&pr[p * h..(p + 1) * h], &pi[p * h..(p + 1) * h]);
            for k in 0..h {
                buf[k] = Complex::new(re[k], im[k]);
            }
            for k in h..m {
                buf[k] = Complex::new(re[m - k], -im[m - k]);
            }
            if tr.inverse(buf).is_err() {
                return;
            }
            for d in 0..span {
                s[(d * nz + c) * nz + e] += buf[d].re * scale;
                if c != e {
                    s[(d * nz + e) * nz + c] += buf[(m - d) % m].re * scale;
                }
            }
            p += 1;
        }
    }
}

/// The spectra of channels c (real part of the packed block) and c + 1
/// (imaginary part) from the transform of the packed block
/// ([`lifted_linalg::fft::split_packed`]), split into real and imaginary
/// parts for the accumulation.
fn unpack(buf: &[Complex<f64>], two: bool, c: usize, h: usize, xr: &mut [f64], xi: &mut [f64]) {
    let (ar, br) = xr[c * h..].split_at_mut(h);
    let (ai, bi) = xi[c * h..].split_at_mut(h);
    if !two {
        for k in 0..h {
            ar[k] = buf[k].re;
            ai[k] = buf[k].im;
        }
        return;
    }
    let (br, bi) = (&mut br[..h], &mut bi[..h]);
    lifted_linalg::simd::dispatch(
        #[inline(always)]
        || {
            for k in 0..h {
                let (a, b) = split_packed(buf, k);
                (ar[k], ai[k], br[k], bi[k]) = (a.re, a.im, b.re, b.im);
            }
        },
    );
}

/// P_ce += conj(X_c) X_e for every pair c ≤ e, frequencies in chunks that
/// keep the chunk's sums and spectra in the first-level cache.
fn accumulate(nz: usize, h: usize, xr: &[f64], xi: &[f64], pr: &mut [f64], pi: &mut [f64]) {
    const CHUNK: usize = 64;
    lifted_linalg::simd::dispatch(
        #[inline(always)]
        || {
            let mut k0 = 0;
            while k0 < h {
                let k1 = (k0 + CHUNK).min(h);
                let mut p = 0;
                for c in 0..nz {
                    let (ar, ai) = (&xr[c * h + k0..c * h + k1], &xi[c * h + k0..c * h + k1]);
                    for e in c..nz {
                        let (br, bi) = (&xr[e * h + k0..e * h + k1], &xi[e * h + k0..e * h + k1]);
                        let o = p * h;
                        let (sr, si) = (&mut pr[o + k0..o + k1], &mut pi[o + k0..o + k1]);
                        for k in 0..k1 - k0 {
                            sr[k] += ar[k] * br[k] + ai[k] * bi[k];
                            si[k] += ar[k] * bi[k] - ai[k] * br[k];
                        }
                        p += 1;
                    }
                }
                k0 = k1;
            }
        },
    );
}

/// The pairs of instants that straddle the block's end: t < lb ≤ t + δ,
/// δ < span, added to S directly (δ products at lag δ).
/// For each pair, the instants t ≥ lb − span + 1 in turn, each adding
/// z_c(t) z_e(t + δ) for its lags δ > lb − 1 − t into a span-long row of
/// sums (independent sums along δ: the loop vectorises), then added to S.
/// O(n_z² span²/2).
fn straddling(
    cols: &[Vec<f64>],
    nz: usize,
    span: usize,
    lb: usize,
    s: &mut [f64],
    row: &mut Vec<f64>,
) {
    row.resize(span, 0.0);
    let from = (lb + 1).saturating_sub(span);
    for c in 0..nz {
        for e in 0..nz {
            row.fill(0.0);
            let (a, b) = (&cols[c], &cols[e]);
            lifted_linalg::simd::dispatch(
                #[inline(always)]
                || {
                    for t in from..lb {
                        let d0 = lb - t;
                        let x = a[t];
                        for (r, y) in row[d0..].iter_mut().zip(&b[t + d0..t + span]) {
                            *r += x * y;
                        }
                    }
                },
            );
            for (d, v) in row.iter().enumerate().skip(1) {
                s[(d * nz + c) * nz + e] += v;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::lagged::tests::naive;

    /// Seeded signals with channels of different scales and means.
    fn signals(nz: usize, n: usize, seed: u64) -> Vec<Vec<f64>> {
        let mut z = crate::lagged::tests::signals(nz, n, seed);
        for (c, ch) in z.iter_mut().enumerate() {
            ch.iter_mut()
                .for_each(|v| *v = (*v + 0.2) * (1.0 + c as f64));
        }
        z
    }

    /// Odd and even channel counts, spans at and above the threshold,
    /// lengths of whole and partial blocks: the sums equal the direct ones
    /// to rounding (relative to Σ |z_c| |z_e|), also accumulated onto what
    /// the output held, and with a carried prefix scaled and centred.
    #[test]
    fn the_fft_sums_are_the_lagged_sums() {
        for nz in [1, 2, 3, 4, 5] {
            for span in [FFT_MIN_SPAN, 40, 57] {
                let l = block_length(span) - span + 1;
                for len in [1, l - 1, l, 4 * l + 17] {
                    let z = signals(nz, len + span, (nz * 1000 + span * 10 + len) as u64);
                    let want = naive(&z, span, len);
                    let (scale, offset, held) = (2.0, 0.5, 5.min(len));
                    let raw: Vec<Vec<f64>> = z
                        .iter()
                        .map(|c| c.iter().map(|v| (v + offset) / scale).collect())
                        .collect();
                    let ch: Vec<Channel<'_>> = (0..nz)
                        .map(|c| Channel {
                            carry: &z[c][..held],
                            new: &raw[c][held..],
                            scale,
                            offset,
                        })
                        .collect();
                    let mut got = vec![1.0; want.len()];
                    fft_sums(&ch, span, len, &mut got, &mut FftScratch::default());
                    let bound = 1e-13 * len as f64 * (nz * nz) as f64;
                    for (g, w) in got.iter().zip(&want) {
                        assert!(
                            (g - 1.0 - w).abs() <= bound,
                            "nz {nz} span {span} len {len}: {g} vs {w}"
                        );
                    }
                }
            }
        }
    }

    /// The lagged kernel's entry point takes this path for a long call and
    /// gives the naive sums.
    #[test]
    fn the_kernel_entry_takes_the_fft_path_for_long_calls() {
        let (nz, span, len) = (2, 40, FFT_MIN_LEN + 5);
        assert!(worth_it(span, len));
        let z = signals(nz, len + span, 5);
        let ch: Vec<Channel<'_>> = z.iter().map(|c| Channel::plain(c)).collect();
        let want = naive(&z, span, len);
        let mut got = vec![0.0; want.len()];
        crate::lagged::channel_sums(&ch, span, len, &mut got, &mut Default::default());
        for (g, w) in got.iter().zip(&want) {
            assert!((g - w).abs() <= 1e-13 * len as f64, "{g} vs {w}");
        }
    }

    #[test]
    fn short_calls_and_short_spans_stay_direct() {
        assert!(!worth_it(FFT_MIN_SPAN - 1, 1 << 20));
        assert!(!worth_it(40, FFT_MIN_LEN - 1));
        assert!(worth_it(40, FFT_MIN_LEN));
        // A span long enough that four blocks exceed the length floor.
        let l = block_length(1000) - 1000 + 1;
        assert!(!worth_it(1000, 4 * l - 1) && worth_it(1000, 4 * l));
    }

    #[test]
    fn the_work_space_is_reused_across_calls_and_spans() {
        let z = signals(3, 3000, 7);
        let refs: Vec<Channel<'_>> = z.iter().map(|c| Channel::plain(c)).collect();
        let mut w = FftScratch::default();
        for span in [40, 33, 40] {
            let len = 3000 - span;
            let want = naive(&z, span, len);
            let mut got = vec![0.0; want.len()];
            fft_sums(&refs, span, len, &mut got, &mut w);
            for (g, x) in got.iter().zip(&want) {
                assert!((g - x).abs() <= 1e-11, "span {span}: {g} vs {x}");
            }
        }
    }
}

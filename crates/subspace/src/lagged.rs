//! The lagged-correlation kernel of the structured Hankel compression:
//! S_ce(δ) += Σ_{t<len} z_c(t) z_e(t + δ) for every channel pair (c, e)
//! and lag δ < span.
//!
//! With the channels interleaved in time-major order (zᵢ[t n_z + e]), the
//! row of all lagged values z_e(t + δ), δ < span, e < n_z, is the contiguous
//! window zᵢ[t n_z .. (t + span) n_z]; the sums are then the product of the
//! n_z × len matrix of present values with the len × (span n_z) Hankel
//! block, a GEMM whose second operand is a strided view of the data (no
//! copy but the interleaving). The AVX2/FMA kernel keeps a 4 × 12 tile of
//! sums in 12 vector registers and streams the instants of a cache block
//! through it: per instant 3 vector loads, 4 broadcasts and 12 FMAs, so it
//! runs at the machine's FMA rate (≈ 640 FMA lanes per sample for n_z = 4,
//! span = 40: ≈ 80 cycles per sample on AVX2). Without AVX2/FMA (detected at
//! run time) the portable kernel vectorises one channel pair and four lags at
//! a time.
//!
//! The channels come as [`Channel`]s: values already prepared (the s − 1
//! samples a stream carries between blocks) followed by raw samples that
//! are scaled and centred while they are interleaved, so a streamed block
//! is read once from the caller's matrices (no working copy).
//!
//! Calls with a span of at least [`fft::FFT_MIN_SPAN`] and at least
//! [`fft::FFT_MIN_LEN`] instants (and four FFT blocks) go to the [`fft`]
//! module instead (the same sums to rounding, O(n_z log span + n_z² +
//! n_z² span/64) operations per instant).
//!
//! Cost: 2 len n_z² span flops; memory: one interleaved block of
//! (KERNEL_BLOCK + span − 1) n_z values and the n_z × span n_z tile sums,
//! kept in the caller's [`Scratch`].

mod fft;

/// Time instants processed per cache block (the interleaved block is
/// (4000 + span − 1) × n_z × 8 bytes: 126 KiB for n_z = 4 and span 40,
/// resident in L2, and under glibc's 128 KiB threshold for allocating by
/// mmap, so the work space comes from the heap without an mmap/munmap and
/// fresh page faults per identification: 0.04 ms of a fresh 1e4
/// identification against 4096 instants, measured 2026-11-25).
pub(crate) const KERNEL_BLOCK: usize = 4000;

/// Work space of the kernel, kept by the caller across calls so that
/// streaming blocks allocate nothing.
#[derive(Debug, Default)]
pub(crate) struct Scratch {
    /// One interleaved block (the x86-64 tiles).
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    zi: Vec<f64>,
    /// The n_z × span n_z sums of a call (the x86-64 tiles).
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    tile: Vec<f64>,
    /// One block per channel (portable kernel).
    flat: Vec<Vec<f64>>,
    /// The FFT path's work space (long spans).
    fft: fft::FftScratch,
}

/// One channel of the data: z(t) = `carry[t]` for t < carry.len(), then
/// z(t) = `new[t − carry.len()]` · `scale` − `offset`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Channel<'a> {
    /// Prepared values (already scaled and centred).
    pub carry: &'a [f64],
    /// Raw samples.
    pub new: &'a [f64],
    /// Factor applied to `new`.
    pub scale: f64,
    /// Subtracted from `new` after scaling.
    pub offset: f64,
}

impl<'a> Channel<'a> {
    /// A channel of prepared values.
    #[cfg(test)]
    pub(crate) fn plain(z: &'a [f64]) -> Self {
        Channel {
            carry: z,
            new: &[],
            scale: 1.0,
            offset: 0.0,
        }
    }

    /// z(t).
    pub(crate) fn at(&self, t: usize) -> f64 {
        match self.carry.get(t) {
            Some(v) => *v,
            None => self.new[t - self.carry.len()] * self.scale - self.offset,
        }
    }

    /// The channel without its first `t` samples.
    pub(crate) fn skip(&self, t: usize) -> Self {
        let h = self.carry.len();
        if t <= h {
            Channel {
                carry: &self.carry[t..],
                ..*self
            }
        } else {
            Channel {
                carry: &[],
                new: &self.new[t - h..],
                ..*self
            }
        }
    }

    /// out[i stride + e] = z(t0 + i) for i < rows.
    #[inline]
    pub(crate) fn write(&self, t0: usize, rows: usize, out: &mut [f64], stride: usize, e: usize) {
        let h = self.carry.len();
        let mut i = 0;
        if t0 < h {
            let m = (h - t0).min(rows);
            for (k, v) in self.carry[t0..t0 + m].iter().enumerate() {
                out[k * stride + e] = *v;
            }
            i = m;
        }
        if i < rows {
            let from = t0 + i - h;
            let (sc, off) = (self.scale, self.offset);
            let dst = &mut out[i * stride..];
            let src = &self.new[from..from + rows - i];
            if stride == 1 {
                // Contiguous (the FFT path's and the portable kernel's
                // blocks): the loop vectorises.
                for (d, x) in dst[e..].iter_mut().zip(src) {
                    *d = x * sc - off;
                }
            } else {
                for (k, x) in src.iter().enumerate() {
                    dst[k * stride + e] = x * sc - off;
                }
            }
        }
    }
}

/// S[(δ n_z + c) n_z + e] += Σ_{t<len} z_c(t) z_e(t + δ), δ < span, for
/// channel slices with at least `len + span − 1` samples each. Blocks of
/// [`KERNEL_BLOCK`] instants keep the operands in cache.
#[cfg(test)]
pub(crate) fn lagged_sums(
    z: &[&[f64]],
    span: usize,
    len: usize,
    s: &mut [f64],
    scratch: &mut Scratch,
) {
    let ch: Vec<Channel<'_>> = z.iter().map(|z| Channel::plain(z)).collect();
    channel_sums(&ch, span, len, s, scratch);
}

/// [`lagged_sums`] on [`Channel`]s (at least `len + span − 1` samples each).
pub(crate) fn channel_sums(
    z: &[Channel<'_>],
    span: usize,
    len: usize,
    s: &mut [f64],
    scratch: &mut Scratch,
) {
    if fft::worth_it(span, len) {
        fft::fft_sums(z, span, len, s, &mut scratch.fft);
        return;
    }
    #[cfg(target_arch = "x86_64")]
    {
        if let Some(tiles) = tiles::Tiles::detect() {
            interleaved_sums(z, span, len, s, scratch, tiles);
            return;
        }
    }
    portable_channel_sums(z, span, len, s, scratch);
}

/// [`channel_sums`] split into `threads` contiguous ranges of instants
/// (std scoped threads; each range reads `span − 1` samples past its end
/// and interleaves its own samples), each thread with its own work space
/// from `scratch`. The partial sums are added in a fixed order, so the
/// result depends on `threads` only through rounding.
pub(crate) fn channel_sums_par(
    z: &[Channel<'_>],
    span: usize,
    len: usize,
    s: &mut [f64],
    threads: usize,
    scratch: &mut [Scratch],
) {
    let threads = threads
        .max(1)
        .min(len / KERNEL_BLOCK)
        .min(scratch.len())
        .max(1);
    if threads == 1 {
        if let Some(w) = scratch.first_mut() {
            channel_sums(z, span, len, s, w);
        }
        return;
    }
    let per = len.div_ceil(threads);
    let slen = s.len();
    let (first, rest) = scratch.split_at_mut(1);
    let partial: Vec<Option<Vec<f64>>> = std::thread::scope(|scope| {
        let handles: Vec<_> = rest
            .iter_mut()
            .take(threads - 1)
            .enumerate()
            .map(|(i, w)| scope.spawn(move || range_sums(z, span, len, per, i + 1, slen, w)))
            .collect();
        // The calling thread takes the first range.
        channel_sums(z, span, per.min(len), s, &mut first[0]);
        handles.into_iter().map(|h| h.join().ok()).collect()
    });
    for (i, p) in partial.into_iter().enumerate() {
        // A range whose thread failed is summed again here (never skipped).
        let p = p.unwrap_or_else(|| range_sums(z, span, len, per, i + 1, slen, &mut first[0]));
        for (a, b) in s.iter_mut().zip(p) {
            *a += b;
        }
    }
}

/// The sums of range `r` (instants r·per … (r+1)·per − 1 as column starts)
/// of [`channel_sums_par`], into a fresh vector of `slen` entries.
fn range_sums(
    z: &[Channel<'_>],
    span: usize,
    len: usize,
    per: usize,
    r: usize,
    slen: usize,
    w: &mut Scratch,
) -> Vec<f64> {
    let start = r * per;
    let part = per.min(len.saturating_sub(start));
    let mut acc = vec![0.0; slen];
    if part > 0 {
        let zz: Vec<Channel<'_>> = z.iter().map(|c| c.skip(start)).collect();
        channel_sums(&zz, span, part, &mut acc, w);
    }
    acc
}

/// The register tiles this CPU can run, as a proof: made only by
/// [`Tiles::detect`](tiles::Tiles::detect) (its fields are private to this
/// module), so a kernel given one may use AVX2 and FMA, and the 512-bit
/// tiles when `wide()`.
#[cfg(target_arch = "x86_64")]
mod tiles {
    use lifted_linalg::simd::Avx2Fma;

    #[derive(Clone, Copy)]
    pub(super) struct Tiles {
        /// The proof of AVX2 and FMA.
        _simd: Avx2Fma,
        wide: bool,
    }

    impl Tiles {
        /// AVX2 and FMA found (the token), and whether AVX-512F too.
        pub(super) fn detect() -> Option<Tiles> {
            Avx2Fma::detect().map(|simd| Tiles {
                _simd: simd,
                wide: std::is_x86_feature_detected!("avx512f"),
            })
        }

        /// The same CPU restricted to the 256-bit tiles.
        #[cfg(test)]
        pub(super) fn narrow(self) -> Tiles {
            Tiles {
                wide: false,
                ..self
            }
        }

        /// Whether the 512-bit tiles may run (AVX-512F detected).
        pub(super) fn wide(self) -> bool {
            self.wide
        }
    }
}

/// The tiled kernel over interleaved blocks (x86-64 with AVX2 and FMA;
/// 512-bit tiles first where `tiles` allows them).
#[cfg(target_arch = "x86_64")]
fn interleaved_sums(
    z: &[Channel<'_>],
    span: usize,
    len: usize,
    s: &mut [f64],
    w: &mut Scratch,
    tiles: tiles::Tiles,
) {
    let nz = z.len();
    if nz == 0 || span == 0 || len == 0 {
        return;
    }
    let cols = span * nz;
    let need = (KERNEL_BLOCK.min(len) + span - 1) * nz;
    if w.zi.len() < need {
        w.zi.resize(need, 0.0);
    }
    w.tile.clear();
    w.tile.resize(nz * cols, 0.0);
    let (zi, tile) = (&mut w.zi, &mut w.tile);
    let mut t0 = 0;
    while t0 < len {
        let bl = KERNEL_BLOCK.min(len - t0);
        let rows = bl + span - 1;
        for (e, ze) in z.iter().enumerate() {
            ze.write(t0, rows, zi, nz, e);
        }
        block_product(&zi[..rows * nz], nz, span, bl, tile, tiles);
        t0 += bl;
    }
    for c in 0..nz {
        for j in 0..cols {
            // j = δ n_z + e
            s[(j / nz * nz + c) * nz + j % nz] += tile[c * cols + j];
        }
    }
}

/// tile[c cols + j] += Σ_{t<len} zi[t n_z + c] zi[t n_z + j], j < cols =
/// span n_z, over the interleaved block `zi` ((len + span − 1) n_z values).
#[cfg(target_arch = "x86_64")]
fn block_product(
    zi: &[f64],
    nz: usize,
    span: usize,
    len: usize,
    tile: &mut [f64],
    tiles: tiles::Tiles,
) {
    let cols = span * nz;
    debug_assert!(zi.len() >= (len + span - 1) * nz && tile.len() >= nz * cols);
    let mut c0 = 0;
    while c0 < nz {
        let r = (nz - c0).min(4);
        let mut j0 = 0;
        // Widest tiles first: 24 and 8 columns (AVX-512), then 12 and 4.
        let plan: &[(Lanes, usize)] = if tiles.wide() {
            &[
                (Lanes::Eight, 3),
                (Lanes::Eight, 1),
                (Lanes::Four, 3),
                (Lanes::Four, 1),
            ]
        } else {
            &[(Lanes::Four, 3), (Lanes::Four, 1)]
        };
        for &(lanes, v) in plan {
            let w = lanes.width() * v;
            while j0 + w <= cols {
                micro_dispatch(tiles, lanes, r, v, zi, nz, c0, j0, len, tile, cols);
                j0 += w;
            }
        }
        // Fewer than four columns left (odd n_z): scalar.
        for c in c0..c0 + r {
            for j in j0..cols {
                let mut acc = 0.0;
                for t in 0..len {
                    acc = zi[t * nz + c].mul_add(zi[t * nz + j], acc);
                }
                tile[c * cols + j] += acc;
            }
        }
        c0 += r;
    }
}

/// Vector width of a register tile: 4 lanes (AVX2 + FMA) or 8 (AVX-512F).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
enum Lanes {
    Four,
    Eight,
}

#[cfg(target_arch = "x86_64")]
impl Lanes {
    /// Columns per vector.
    fn width(self) -> usize {
        match self {
            Lanes::Four => 4,
            Lanes::Eight => 8,
        }
    }
}

/// Runs the `r` × `lanes`·`v` register tile at (c0, j0) after checking
/// every index it touches, so that the unchecked kernel stays in bounds.
#[cfg(target_arch = "x86_64")]
#[allow(clippy::too_many_arguments)]
fn micro_dispatch(
    tiles: tiles::Tiles,
    lanes: Lanes,
    r: usize,
    v: usize,
    zi: &[f64],
    nz: usize,
    c0: usize,
    j0: usize,
    len: usize,
    tile: &mut [f64],
    cols: usize,
) {
    let w = lanes.width() * v;
    // Reads: zi[t nz + c0 + r − 1] and zi[t nz + j0 + w − 1] for t < len;
    // writes: tile[(c0 + r − 1) cols + j0 + w − 1].
    let last_read = (len.max(1) - 1) * nz + (c0 + r).max(j0 + w) - 1;
    assert!(
        len > 0 && c0 + r <= nz && j0 + w <= cols && last_read < zi.len(),
        "lagged-sum tile out of range"
    );
    assert!((c0 + r - 1) * cols + j0 + w <= tile.len());
    assert!(
        matches!(lanes, Lanes::Four) || tiles.wide(),
        "512-bit tile without AVX-512F"
    );
    // SAFETY: `tiles` proves AVX2 and FMA (its token) and, for
    // `Lanes::Eight`, AVX-512F (`wide()`, asserted above); the asserts
    // above bound every pointer offset the kernel forms: reads below
    // zi.len(), writes below tile.len().
    unsafe {
        let (zp, tp) = (zi.as_ptr(), tile.as_mut_ptr());
        macro_rules! run {
            ($k:ident) => {
                match (r, v) {
                    (4, 3) => $k::<4, 3>(zp, nz, c0, j0, len, tp, cols),
                    (3, 3) => $k::<3, 3>(zp, nz, c0, j0, len, tp, cols),
                    (2, 3) => $k::<2, 3>(zp, nz, c0, j0, len, tp, cols),
                    (1, 3) => $k::<1, 3>(zp, nz, c0, j0, len, tp, cols),
                    (4, _) => $k::<4, 1>(zp, nz, c0, j0, len, tp, cols),
                    (3, _) => $k::<3, 1>(zp, nz, c0, j0, len, tp, cols),
                    (2, _) => $k::<2, 1>(zp, nz, c0, j0, len, tp, cols),
                    _ => $k::<1, 1>(zp, nz, c0, j0, len, tp, cols),
                }
            };
        }
        match lanes {
            Lanes::Four => run!(micro),
            Lanes::Eight => run!(micro_512),
        }
    }
}

/// Defines a register-tile kernel: R rows (channels c0 …) × V vectors of
/// `$lanes` columns (j0 …), accumulated over `len` instants and added to
/// the tile sums.
macro_rules! tile_kernel {
    ($(#[$doc:meta])* $name:ident, $feature:literal, $lanes:literal,
     $zero:ident, $load:ident, $splat:ident, $fma:ident, $add:ident, $store:ident) => {
        $(#[$doc])*
        ///
        /// # Safety
        /// The CPU features must be available; zi[t nz + c0 + R − 1] and
        /// zi[t nz + j0 + lanes·V − 1] must be readable for t < len and
        /// out[(c0 + R − 1) ld + j0 + lanes·V − 1] writable (checked by
        /// [`micro_dispatch`]).
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = $feature)]
        unsafe fn $name<const R: usize, const V: usize>(
            zi: *const f64,
            nz: usize,
            c0: usize,
            j0: usize,
            len: usize,
            out: *mut f64,
            ld: usize,
        ) {
            use std::arch::x86_64::{$add, $fma, $load, $splat, $store, $zero};
            // SAFETY: the caller guarantees the CPU features and the bounds
            // of every offset formed below (see the safety section).
            unsafe {
                let mut acc = [[$zero(); V]; R];
                let mut p = zi;
                for _ in 0..len {
                    let mut b = [$zero(); V];
                    for (k, bk) in b.iter_mut().enumerate() {
                        *bk = $load(p.add(j0 + $lanes * k));
                    }
                    for (r, row) in acc.iter_mut().enumerate() {
                        let x = $splat(*p.add(c0 + r));
                        for (a, bk) in row.iter_mut().zip(&b) {
                            *a = $fma(x, *bk, *a);
                        }
                    }
                    p = p.add(nz);
                }
                for (r, row) in acc.iter().enumerate() {
                    for (k, a) in row.iter().enumerate() {
                        let o = out.add((c0 + r) * ld + j0 + $lanes * k);
                        $store(o, $add($load(o), *a));
                    }
                }
            }
        }
    };
}

tile_kernel!(
    /// The AVX2 tile: vectors of 4 columns (12 ymm accumulators for 4 × 12).
    micro, "avx2,fma", 4, _mm256_setzero_pd, _mm256_loadu_pd, _mm256_set1_pd,
    _mm256_fmadd_pd, _mm256_add_pd, _mm256_storeu_pd
);

tile_kernel!(
    /// The AVX-512 tile: vectors of 8 columns (12 zmm accumulators for 4 × 24).
    micro_512, "avx512f", 8, _mm512_setzero_pd, _mm512_loadu_pd, _mm512_set1_pd,
    _mm512_fmadd_pd, _mm512_add_pd, _mm512_storeu_pd
);

/// Σ_{t<len} a(t) b(t + δ) for the four lags δ = d … d+3 at once (the load
/// of `a` is shared; eight partial sums per lag are vectorised).
#[inline]
fn dot4(a: &[f64], b: &[f64], d: usize, len: usize) -> [f64; 4] {
    let mut acc = [[0.0f64; 8]; 4];
    let n8 = len / 8 * 8;
    let mut t = 0;
    while t < n8 {
        let x: &[f64; 8] = a[t..t + 8].try_into().unwrap_or(&[0.0; 8]);
        for (l, al) in acc.iter_mut().enumerate() {
            let s = t + d + l;
            let y: &[f64; 8] = b[s..s + 8].try_into().unwrap_or(&[0.0; 8]);
            for i in 0..8 {
                al[i] = x[i].mul_add(y[i], al[i]);
            }
        }
        t += 8;
    }
    let mut out = [0.0; 4];
    for (l, al) in acc.iter().enumerate() {
        let mut v = ((al[0] + al[4]) + (al[1] + al[5])) + ((al[2] + al[6]) + (al[3] + al[7]));
        for tt in n8..len {
            v = a[tt].mul_add(b[tt + d + l], v);
        }
        out[l] = v;
    }
    out
}

/// The portable kernel: one channel pair and four lags at a time.
fn portable_channel_sums(
    z: &[Channel<'_>],
    span: usize,
    len: usize,
    s: &mut [f64],
    w: &mut Scratch,
) {
    let nz = z.len();
    w.flat.resize_with(nz, Vec::new);
    let mut t0 = 0;
    while t0 < len {
        let bl = KERNEL_BLOCK.min(len - t0);
        let rows = bl + span - 1;
        for (ze, f) in z.iter().zip(w.flat.iter_mut()) {
            f.resize(rows, 0.0);
            ze.write(t0, rows, f, 1, 0);
        }
        portable_block(&w.flat, span, bl, s);
        t0 += bl;
    }
}

/// The portable sums over one block of prepared channels (`bl` instants,
/// each channel `bl + span − 1` values long).
fn portable_block(z: &[Vec<f64>], span: usize, bl: usize, s: &mut [f64]) {
    let nz = z.len();
    for (c, zc) in z.iter().enumerate() {
        let a = &zc[..bl];
        for (e, ze) in z.iter().enumerate() {
            let b = &ze[..bl + span - 1];
            let mut d = 0;
            while d + 4 <= span {
                let v = dot4(a, b, d, bl);
                for (l, vl) in v.iter().enumerate() {
                    s[((d + l) * nz + c) * nz + e] += vl;
                }
                d += 4;
            }
            while d < span {
                let v: f64 = a.iter().zip(&b[d..]).map(|(x, y)| x * y).sum();
                s[(d * nz + c) * nz + e] += v;
                d += 1;
            }
        }
    }
}

/// The portable kernel on channel slices (tests compare it with the
/// dispatched one on machines with AVX2).
#[cfg(test)]
pub(crate) fn portable_sums(z: &[&[f64]], span: usize, len: usize, s: &mut [f64]) {
    let ch: Vec<Channel<'_>> = z.iter().map(|z| Channel::plain(z)).collect();
    portable_channel_sums(&ch, span, len, s, &mut Scratch::default());
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The lagged sums by their definition (shared with the `fft` module's tests).
    pub(crate) fn naive(z: &[Vec<f64>], span: usize, len: usize) -> Vec<f64> {
        let nz = z.len();
        let mut s = vec![0.0; span * nz * nz];
        for d in 0..span {
            for c in 0..nz {
                for e in 0..nz {
                    s[(d * nz + c) * nz + e] = (0..len).map(|t| z[c][t] * z[e][t + d]).sum();
                }
            }
        }
        s
    }

    /// Seeded uniform signals in [−0.5, 0.5) (xorshift).
    pub(crate) fn signals(nz: usize, n: usize, seed: u64) -> Vec<Vec<f64>> {
        let mut st = seed | 1;
        (0..nz)
            .map(|_| {
                (0..n)
                    .map(|_| {
                        st ^= st << 13;
                        st ^= st >> 7;
                        st ^= st << 17;
                        (st >> 11) as f64 / (1u64 << 53) as f64 - 0.5
                    })
                    .collect()
            })
            .collect()
    }

    /// Every channel count (tile rows 1–4 and remainders), spans whose
    /// column count leaves 24-, 8-, 12-, 4- and scalar remainders, lengths
    /// across the cache block: the dispatched kernel (AVX-512 where the CPU
    /// has it), the AVX2 tiles and the portable kernel equal the naive sums.
    #[test]
    fn kernels_equal_the_naive_sums() {
        for nz in 1..=7 {
            for span in [1, 2, 3, 5, 7, 13, 40] {
                for len in [1, 9, KERNEL_BLOCK + 17] {
                    let z = signals(nz, len + span, (nz * 1000 + span * 10 + len) as u64);
                    let refs: Vec<&[f64]> = z.iter().map(Vec::as_slice).collect();
                    let want = naive(&z, span, len);
                    let scale = len as f64;
                    let mut got = vec![0.0; want.len()];
                    lagged_sums(&refs, span, len, &mut got, &mut Scratch::default());
                    let mut port = vec![0.0; want.len()];
                    portable_sums(&refs, span, len, &mut port);
                    // The AVX2 tiles alone, also where AVX-512 is used.
                    #[cfg(target_arch = "x86_64")]
                    if let Some(tiles) = tiles::Tiles::detect() {
                        let ch: Vec<Channel<'_>> = refs.iter().map(|z| Channel::plain(z)).collect();
                        let mut narrow = vec![0.0; want.len()];
                        let mut w = Scratch::default();
                        interleaved_sums(&ch, span, len, &mut narrow, &mut w, tiles.narrow());
                        for (g, w) in narrow.iter().zip(&want) {
                            assert!((g - w).abs() <= 1e-12 * scale, "avx2 nz {nz} span {span}");
                        }
                    }
                    for ((g, p), w) in got.iter().zip(&port).zip(&want) {
                        assert!(
                            (g - w).abs() <= 1e-12 * scale,
                            "nz {nz} span {span} len {len}"
                        );
                        assert!(
                            (p - w).abs() <= 1e-12 * scale,
                            "nz {nz} span {span} len {len}"
                        );
                    }
                }
            }
        }
    }

    /// Channels that carry prepared values and scale and centre raw ones,
    /// split over two threads, give the sums of the prepared data.
    #[test]
    fn channels_scale_and_centre_while_interleaving() {
        let nz = 3;
        let (span, held, n) = (7, 6, 3 * KERNEL_BLOCK + 50);
        let raw = signals(nz, n, 11);
        let (scale, offset) = (2.5, 0.75);
        let prepared: Vec<Vec<f64>> = raw
            .iter()
            .map(|r| r.iter().map(|x| x * scale - offset).collect())
            .collect();
        let len = n - span + 1;
        let want = naive(&prepared, span, len);
        for threads in [1, 2] {
            let ch: Vec<Channel<'_>> = (0..nz)
                .map(|c| Channel {
                    carry: &prepared[c][..held],
                    new: &raw[c][held..],
                    scale,
                    offset,
                })
                .collect();
            let mut got = vec![0.0; want.len()];
            let mut work = [Scratch::default(), Scratch::default()];
            channel_sums_par(&ch, span, len, &mut got, threads, &mut work);
            let mut port = vec![0.0; want.len()];
            portable_channel_sums(&ch, span, len, &mut port, &mut Scratch::default());
            for ((g, p), w) in got.iter().zip(&port).zip(&want) {
                assert!((g - w).abs() <= 1e-12 * n as f64, "{threads}: {g} vs {w}");
                assert!((p - w).abs() <= 1e-12 * n as f64, "{threads}: {p} vs {w}");
            }
        }
    }

    #[test]
    fn sums_accumulate_into_the_output() {
        let z = signals(2, 50, 3);
        let refs: Vec<&[f64]> = z.iter().map(Vec::as_slice).collect();
        let mut s = vec![1.0; 3 * 4];
        let mut w = Scratch::default();
        lagged_sums(&refs, 3, 40, &mut s, &mut w);
        // The work space is reused: a second call adds the same sums again.
        lagged_sums(&refs, 3, 40, &mut s, &mut w);
        let want = naive(&z, 3, 40);
        for (g, w) in s.iter().zip(&want) {
            assert!((g - (2.0 * w + 1.0)).abs() < 1e-12);
        }
    }
}

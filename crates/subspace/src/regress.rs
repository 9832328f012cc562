//! Estimation of (B, D, x₀) for given (A, C): least squares (open loop) or
//! instrumental variables (closed loop), with a causality mask on D, and the
//! structured state-space least squares of thesis §4.5 (eqs. 4.17–4.19).
//!
//! The output is linear in θ = (vec B, allowed entries of D, x₀ per record):
//! y(t) = C Aᵗ x₀ + Σ_{τ<t} C A^{t−1−τ} B u(τ) + D u(t) + noise.
//! The regressors C Z_j(t), Z_j(t+1) = A Z_j(t) + u_j(t) I, are generated
//! by a recursion (n³ flops per input and sample) and streamed in row
//! blocks: least squares through an R-only QR of [Φ | y]
//! ([`lifted_linalg::RAccumulator`]) — for a well-conditioned modal form of
//! A through n scalar filters per input and one short base row per sample
//! instead (`modal.rs`: the same R to rounding, ≈ 2.5× fewer flops
//! for 2×2 order 4) — instrumental variables through the
//! p×p normal matrix Σ ζ φᵀ with instruments ζ built by the same filters from
//! the instrument signal (spec A3.9: "f-filtered instruments"). Memory is
//! O(p²) for p parameters, independent of the record length. Per-output
//! regressor selection keeps masked entries of D at exactly zero (Pitfall 5:
//! never zero entries after an unconstrained fit). Outputs that are NaN
//! (unsampled instants of multirate records) are skipped.

use lifted_linalg::{RAccumulator, lstsq};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::checks::{check_instrument, check_record_shape};
use crate::error::{Error, Result, check_data, check_rank, non_finite_at};
use crate::estimated::{BdFit, DataScale, Feedthrough, InitialState, Params, Record};
use crate::modal::{self, ModalForm};
use crate::numerics::numerical_rank;
use lifted_linalg::spectral_radius;

/// Largest growth ρ(A)^(N−1) of the simulated regressors accepted by the
/// output-error regressions for an unstable A: 1/√ε = 2²⁶ ≈ 6.7e7. Beyond
/// it the squared regressors (R factor, IV normal matrix) span more than
/// 1/ε, so the first samples of the record are below rounding, and the
/// regression ends in overflow, a failed SVD or a spurious rank deficiency
/// ([`Error::UnstableEstimate`] instead).
pub const MAX_REGRESSOR_GROWTH: f64 = 67_108_864.0;

/// Rejects an unstable A whose simulation over `samples` samples would
/// grow by more than [`MAX_REGRESSOR_GROWTH`] with
/// [`Error::UnstableEstimate`] naming `stage`. One eigenvalue computation,
/// O(n³).
pub(crate) fn check_growth(a: &DMatrix<f64>, samples: usize, stage: &'static str) -> Result<()> {
    if samples < 2 || a.nrows() == 0 {
        return Ok(());
    }
    let rho = spectral_radius(a)?;
    if rho <= 1.0 {
        return Ok(());
    }
    let ln_growth = (samples - 1) as f64 * rho.ln();
    if ln_growth > MAX_REGRESSOR_GROWTH.ln() {
        return Err(Error::UnstableEstimate {
            stage,
            spectral_radius: rho,
            samples,
            growth: ln_growth.exp(),
            max_growth: MAX_REGRESSOR_GROWTH,
        });
    }
    Ok(())
}

/// Generates regressor rows (one per sampled output entry) of one record
/// (owns copies of A and the layout, so that it can live between the
/// blocks of a streamed record).
#[derive(Clone, Serialize, Deserialize)]
struct RowGen {
    a: DMatrix<f64>,
    p: Params,
    record: usize,
    /// Z_j stacked: nu blocks of n×n, column-major per block.
    z: Vec<f64>,
    ztmp: Vec<f64>,
    /// C Aᵗ (ny×n), row-major.
    cat: Vec<f64>,
    cattmp: Vec<f64>,
    /// C (ny×n), row-major.
    c_rows: Vec<f64>,
    /// Factor applied to the signal samples (1/scale, a power of 2).
    inv: f64,
}

impl RowGen {
    fn new(a: &DMatrix<f64>, c: &DMatrix<f64>, p: &Params, record: usize, inv: f64) -> Self {
        let (n, nu, ny) = (p.n, p.nu, p.ny);
        let mut cat = vec![0.0; ny * n];
        for o in 0..ny {
            for s in 0..n {
                cat[o * n + s] = c[(o, s)];
            }
        }
        RowGen {
            a: a.clone(),
            p: p.clone(),
            record,
            z: vec![0.0; nu * n * n],
            ztmp: vec![0.0; nu * n * n],
            c_rows: cat.clone(),
            cat,
            cattmp: vec![0.0; ny * n],
            inv,
        }
    }

    /// Writes the regressor row for output `o` at the current time into `row`.
    #[inline(always)]
    fn row(&self, o: usize, sig: &DMatrix<f64>, t: usize, row: &mut [f64]) {
        let (n, nu) = (self.p.n, self.p.nu);
        row.iter_mut().for_each(|v| *v = 0.0);
        let co = &self.c_rows[o * n..(o + 1) * n];
        for j in 0..nu {
            let zj = &self.z[j * n * n..(j + 1) * n * n];
            for (s, zs) in zj.chunks_exact(n).enumerate() {
                // (C Z_j)[o, s] = Σ_r C[o, r] Z_j[r, s]
                row[j * n + s] = co.iter().zip(zs).map(|(c, z)| c * z).sum();
            }
            if let Some(i) = self.p.d_index[(o, j)] {
                row[i] = sig[(t, j)] * self.inv;
            }
        }
        if let Some(off) = self.p.x0_offset {
            let base = off + self.record * n;
            row[base..base + n].copy_from_slice(&self.cat[o * n..(o + 1) * n]);
        }
        if let Some(off) = self.p.c_offset {
            row[off + self.record * self.p.ny + o] = 1.0;
        }
    }

    /// Advances Z_j and C Aᵗ by one sample with input sig(t).
    #[inline(always)]
    fn step(&mut self, sig: &DMatrix<f64>, t: usize) {
        let (n, nu) = (self.p.n, self.p.nu);
        // Column-major A: column q is ad[q n .. (q + 1) n]; each column of
        // A Z_j is a sum of columns of A (axpy form, vectorised over rows).
        let ad = self.a.as_slice();
        for j in 0..nu {
            let zj = &self.z[j * n * n..(j + 1) * n * n];
            let out = &mut self.ztmp[j * n * n..(j + 1) * n * n];
            let uj = sig[(t, j)] * self.inv;
            match n {
                1 => az_fixed::<1>(ad, zj, out, uj),
                2 => az_fixed::<2>(ad, zj, out, uj),
                3 => az_fixed::<3>(ad, zj, out, uj),
                4 => az_fixed::<4>(ad, zj, out, uj),
                5 => az_fixed::<5>(ad, zj, out, uj),
                6 => az_fixed::<6>(ad, zj, out, uj),
                7 => az_fixed::<7>(ad, zj, out, uj),
                8 => az_fixed::<8>(ad, zj, out, uj),
                _ => az_any(n, ad, zj, out, uj),
            }
        }
        std::mem::swap(&mut self.z, &mut self.ztmp);
        if self.p.x0_offset.is_some() {
            // (C Aᵗ⁺¹)[o, s] = Σ_q (C Aᵗ)[o, q] A[q, s]: row o times column s.
            for (co, out) in self
                .cat
                .chunks_exact(n)
                .zip(self.cattmp.chunks_exact_mut(n))
            {
                for (o, acol) in out.iter_mut().zip(ad.chunks_exact(n)) {
                    *o = co.iter().zip(acol).map(|(c, a)| c * a).sum();
                }
            }
            std::mem::swap(&mut self.cat, &mut self.cattmp);
        }
    }
}

/// out = A Z + u I for n×n column-major A (`ad`) and Z: the sensitivities
/// Z_j of the state to the entries B[·, j] one sample later. Any n.
fn az_any(n: usize, ad: &[f64], zj: &[f64], out: &mut [f64], u: f64) {
    for (s, (zs, os)) in zj.chunks_exact(n).zip(out.chunks_exact_mut(n)).enumerate() {
        os.fill(0.0);
        for (zq, aq) in zs.iter().zip(ad.chunks_exact(n)) {
            for (o, a) in os.iter_mut().zip(aq) {
                *o += a * zq;
            }
        }
        os[s] += u;
    }
}

/// [`az_any`] for a fixed order N (loops unrolled and vectorised by the
/// compiler; the orders of most identifications).
#[inline(always)]
fn az_fixed<const N: usize>(ad: &[f64], zj: &[f64], out: &mut [f64], u: f64) {
    let a = &ad[..N * N];
    for s in 0..N {
        let zs = &zj[s * N..s * N + N];
        let mut col = [0.0f64; N];
        for q in 0..N {
            let zq = zs[q];
            let aq = &a[q * N..q * N + N];
            for r in 0..N {
                col[r] = aq[r].mul_add(zq, col[r]);
            }
        }
        col[s] += u;
        out[s * N..s * N + N].copy_from_slice(&col);
    }
}

fn validate(
    a: &DMatrix<f64>,
    c: &DMatrix<f64>,
    records: &[Record<'_>],
    iv: bool,
) -> Result<(usize, usize, usize)> {
    let n = lifted_linalg::check_square("a", a)?;
    lifted_linalg::check_cols("c", c, n)?;
    lifted_linalg::check_finite("a", a)?;
    lifted_linalg::check_finite("c", c)?;
    let ny = c.nrows();
    let first = records.first().ok_or(Error::NoData)?;
    let nu = first.u.ncols();
    for r in records {
        check_record_shape("record (u, y)", "N", r.u, r.y, nu, ny)?;
        check_data("u", r.u)?;
        // NaN marks an unsampled output; ±∞ is an error (branch-free scan,
        // the first infinite entry in column order).
        if let Some(i) = lifted_linalg::kernels::first_infinite(r.y.as_slice()) {
            return Err(non_finite_at("y", r.y, i));
        }
        if iv && let Some(f) = r.instrument {
            check_instrument(f, r.u)?;
        }
    }
    Ok((n, nu, ny))
}

/// Receiver of streamed (regressor | target) blocks and instrument blocks.
type Sink<'s> = dyn FnMut(&DMatrix<f64>, Option<&DMatrix<f64>>) -> Result<()> + 's;

/// Rows per streamed block.
const BLOCK: usize = 1024;

/// Streams (φ, ζ, y) blocks of all records, divided by `scale`, to `sink`
/// (`c` is the C of the scaled data).
fn stream(
    a: &DMatrix<f64>,
    c: &DMatrix<f64>,
    p: &Params,
    records: &[Record<'_>],
    iv: bool,
    scale: DataScale,
    sink: &mut Sink<'_>,
) -> Result<usize> {
    lifted_linalg::simd::dispatch(
        #[inline(always)]
        || {
            let (iu, iy) = (1.0 / scale.io.u, 1.0 / scale.io.y);
            let np = p.total;
            let mut phi = DMatrix::zeros(BLOCK, np + 1);
            let mut zeta = DMatrix::zeros(if iv { BLOCK } else { 0 }, np);
            let mut row = vec![0.0; np];
            let mut used = 0;
            let mut rows_total = 0;
            for (e, rec) in records.iter().enumerate() {
                let (zsig, iz) = match rec.instrument {
                    Some(f) => (f, 1.0 / scale.z),
                    None => (rec.u, iu),
                };
                let mut g = RowGen::new(a, c, p, e, iu);
                let mut gz = RowGen::new(a, c, p, e, iz);
                for t in 0..rec.u.nrows() {
                    for o in 0..p.ny {
                        let yv = rec.y[(t, o)] * iy;
                        if yv.is_nan() {
                            continue;
                        }
                        g.row(o, rec.u, t, &mut row);
                        for (k, v) in row.iter().enumerate() {
                            phi[(used, k)] = *v;
                        }
                        phi[(used, np)] = yv;
                        if iv {
                            gz.row(o, zsig, t, &mut row);
                            for (k, v) in row.iter().enumerate() {
                                zeta[(used, k)] = *v;
                            }
                        }
                        used += 1;
                        if used == BLOCK {
                            sink(&phi, iv.then_some(&zeta))?;
                            rows_total += used;
                            used = 0;
                        }
                    }
                    g.step(rec.u, t);
                    if iv {
                        gz.step(zsig, t);
                    }
                }
            }
            if used > 0 {
                let ph = phi.rows(0, used).into_owned();
                let zz = zeta.rows(0, if iv { used } else { 0 }).into_owned();
                sink(&ph, iv.then_some(&zz))?;
                rows_total += used;
            }
            Ok(rows_total)
        },
    )
}

/// The set-up shared by [`estimate_bd`] and [`estimate_bd_iv`] (`iv`): the
/// checks (of the instruments too when `iv`), the growth bound, the
/// parameter layout, the data scales and C of the scaled data.
fn bd_problem(
    a: &DMatrix<f64>,
    c: &DMatrix<f64>,
    records: &[Record<'_>],
    feedthrough: &Feedthrough,
    x0: InitialState,
    iv: bool,
    offsets: bool,
) -> Result<(Params, DataScale, DMatrix<f64>)> {
    let stage = if iv {
        "(B, D, x₀) IV regression"
    } else {
        "(B, D, x₀) output-error regression"
    };
    let (n, nu, ny) = validate(a, c, records, iv)?;
    check_growth(a, longest(records), stage)?;
    let mask = feedthrough.mask(ny, nu)?;
    let p = Params::new(n, nu, ny, &mask, x0, records.len(), offsets);
    let scale = DataScale::of(records);
    let c_scaled = c / scale.io.y;
    Ok((p, scale, c_scaled))
}

/// Least-squares estimate of (B, D, x₀) for given (A, C) (output-error
/// regression, open loop). y may contain NaN at unsampled instants.
///
/// Cost O(N q²) with q = n n_u + n_u + n + n_y + 1 through the modal base
/// rows (A with well-conditioned eigenvectors, `modal.rs`),
/// O(N_y·(n_u n³ + p²)) for N_y sampled output entries and p parameters
/// otherwise; memory O(p²) (one q×q factor per pattern of sampled outputs).
///
/// The rank test and the solve are column-equilibrated (each regressor
/// scaled to unit norm), so the units of B, D and x₀ do not matter.
///
/// Errors: [`Error::NoData`], [`Error::DimensionMismatch`],
/// [`Error::NonFinite`], [`Error::RankDeficient`] when the regressors do
/// not determine θ (non-exciting input), [`Error::UnstableEstimate`] when A
/// is unstable and ρ(A)^(N−1) exceeds [`MAX_REGRESSOR_GROWTH`] (checked
/// first, O(n³)).
pub fn estimate_bd(
    a: &DMatrix<f64>,
    c: &DMatrix<f64>,
    records: &[Record<'_>],
    feedthrough: &Feedthrough,
    x0: InitialState,
) -> Result<BdFit> {
    output_error_route(a, c, records, feedthrough, x0, Route::default())
}

/// [`estimate_bd`] with a constant output offset per record and output
/// among the unknowns (y = c + G u + C Aᵗ x₀): for records whose means were
/// removed, where the response that started at rest leaves an O(1/N)
/// constant that the model cannot produce. Same cost and errors (the
/// offsets add n_y parameters per record).
pub fn estimate_bd_with_offsets(
    a: &DMatrix<f64>,
    c: &DMatrix<f64>,
    records: &[Record<'_>],
    feedthrough: &Feedthrough,
    x0: InitialState,
) -> Result<BdFit> {
    output_error_route(
        a,
        c,
        records,
        feedthrough,
        x0,
        Route {
            offsets: true,
            ..Route::default()
        },
    )
}

/// How [`output_error_route`] runs.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Route {
    /// Estimate a constant output offset per record and output
    /// ([`estimate_bd_with_offsets`]).
    pub(crate) offsets: bool,
    /// Take the modal base rows when A's modal form allows it.
    pub(crate) allow_modal: bool,
    /// Threads of the modal accumulation (long records are split).
    pub(crate) threads: usize,
}

impl Default for Route {
    fn default() -> Self {
        Route {
            offsets: false,
            allow_modal: true,
            threads: 1,
        }
    }
}

/// The output-error (B, D, x₀) regression of [`estimate_bd`] (`offsets`:
/// [`estimate_bd_with_offsets`]) through the modal base rows (`modal.rs`) when
/// `allow_modal` and A's modal form is well conditioned, else through the
/// direct recursion (the tests compare the two).
pub(crate) fn output_error_route(
    a: &DMatrix<f64>,
    c: &DMatrix<f64>,
    records: &[Record<'_>],
    feedthrough: &Feedthrough,
    x0: InitialState,
    route: Route,
) -> Result<BdFit> {
    let (p, scale, c_scaled) = bd_problem(a, c, records, feedthrough, x0, false, route.offsets)?;
    let mut acc = RAccumulator::new(p.total + 1);
    let modal = if route.allow_modal && c.nrows() <= modal::MAX_OUTPUTS {
        ModalForm::of(a)
    } else {
        None
    };
    // The modal route gives up (None) on a record with more sampling
    // patterns than it keeps accumulators for; the direct route then starts
    // afresh.
    let fast = match modal {
        Some(form) => modal::accumulate(
            &form,
            &c_scaled,
            &p,
            records,
            scale,
            &mut acc,
            route.threads,
        )?,
        None => None,
    };
    let rows = match fast {
        Some(rows) => rows,
        None => {
            acc = RAccumulator::new(p.total + 1);
            let mut direct = DirectStream::new(a, &c_scaled, &p, scale);
            for rec in records {
                direct.push(rec.u, rec.y, &mut acc)?;
                direct.end_record(&mut acc)?;
            }
            direct.rows()
        }
    };
    check_rank("B/D regressor", rows, p.total)?;
    let r = acc.r();
    let r11 = r.view((0, 0), (p.total, p.total)).into_owned();
    let r12 = r.view((0, p.total), (p.total, 1)).into_owned();
    let theta = equilibrated_solve(&r11, &r12, "B/D regressor")?;
    Ok(p.unpack(&theta, records.len(), scale.io))
}

/// The direct-route output-error regression rows (one per sampled output
/// entry, [`RowGen`]) of consecutive blocks of samples folded into an R
/// accumulator: the regressor recursions carry over between blocks, so a
/// record may arrive in pieces (a second pass over a file). Memory
/// O(BLOCK · p), independent of the record length.
#[derive(Clone, Serialize, Deserialize)]
pub(crate) struct DirectStream {
    rows_of: RowGen,
    a: DMatrix<f64>,
    c: DMatrix<f64>,
    p: Params,
    iu: f64,
    iy: f64,
    block: DMatrix<f64>,
    row: Vec<f64>,
    used: usize,
    rows: usize,
}

impl DirectStream {
    /// A stream for (A, C) with C of the data divided by `scale` (`c`).
    pub(crate) fn new(a: &DMatrix<f64>, c: &DMatrix<f64>, p: &Params, scale: DataScale) -> Self {
        let iu = 1.0 / scale.io.u;
        DirectStream {
            rows_of: RowGen::new(a, c, p, 0, iu),
            a: a.clone(),
            c: c.clone(),
            p: p.clone(),
            iu,
            iy: 1.0 / scale.io.y,
            block: DMatrix::zeros(BLOCK, p.total + 1),
            row: vec![0.0; p.total],
            used: 0,
            rows: 0,
        }
    }

    /// The regression rows of the next samples of the current record.
    pub(crate) fn push(
        &mut self,
        u: &DMatrix<f64>,
        y: &DMatrix<f64>,
        acc: &mut RAccumulator,
    ) -> Result<()> {
        lifted_linalg::simd::dispatch(
            #[inline(always)]
            || {
                let np = self.p.total;
                for t in 0..u.nrows() {
                    for o in 0..self.p.ny {
                        let yv = y[(t, o)] * self.iy;
                        if yv.is_nan() {
                            continue;
                        }
                        self.rows_of.row(o, u, t, &mut self.row);
                        for (k, v) in self.row.iter().enumerate() {
                            self.block[(self.used, k)] = *v;
                        }
                        self.block[(self.used, np)] = yv;
                        self.used += 1;
                        if self.used == BLOCK {
                            self.flush(acc)?;
                        }
                    }
                    self.rows_of.step(u, t);
                }
                Ok(())
            },
        )
    }

    fn flush(&mut self, acc: &mut RAccumulator) -> Result<()> {
        if self.used == BLOCK {
            acc.push_rows(&self.block)?;
        } else if self.used > 0 {
            acc.push_rows(&self.block.rows(0, self.used).into_owned())?;
        }
        self.rows += self.used;
        self.used = 0;
        Ok(())
    }

    /// Ends the current record; the next samples start the next record
    /// from rest (its own x₀ and offset columns).
    pub(crate) fn end_record(&mut self, acc: &mut RAccumulator) -> Result<()> {
        self.flush(acc)?;
        let next = self.rows_of.record + 1;
        self.rows_of = RowGen::new(&self.a, &self.c, &self.p, next, self.iu);
        Ok(())
    }

    /// Rows (sampled output entries) folded so far.
    pub(crate) fn rows(&self) -> usize {
        self.rows + self.used
    }

    /// Advances the recursions over the inputs of the next samples without
    /// making rows (n_u n³ flops per sample).
    pub(crate) fn advance(&mut self, u: &DMatrix<f64>) {
        lifted_linalg::simd::dispatch(
            #[inline(always)]
            || {
                for t in 0..u.nrows() {
                    self.rows_of.step(u, t);
                }
            },
        )
    }

    /// A copy of the stream at its state with no rows, and the accumulator
    /// its rows go to: push a shard's blocks, then
    /// [`into_piece`](Self::into_piece).
    pub(crate) fn scanner(&self) -> (DirectStream, RAccumulator) {
        let s = DirectStream {
            used: 0,
            rows: 0,
            ..self.clone()
        };
        (s, RAccumulator::new(self.p.total + 1))
    }

    /// The R factor and rows pushed to a [`scanner`](Self::scanner).
    pub(crate) fn into_piece(mut self, mut acc: RAccumulator) -> Result<(RAccumulator, usize)> {
        self.flush(&mut acc)?;
        Ok((acc, self.rows))
    }

    /// Adds rows scanned apart (their R factor) to `acc`.
    pub(crate) fn absorb(
        &mut self,
        r: &RAccumulator,
        rows: usize,
        acc: &mut RAccumulator,
    ) -> Result<()> {
        self.flush(acc)?;
        acc.push_rows(&r.r())?;
        self.rows += rows;
        Ok(())
    }

    /// Whether the sizes are those of `p` (a state decoded from bytes).
    pub(crate) fn fits(&self, p: &Params) -> bool {
        let (n, nu, ny) = (p.n, p.nu, p.ny);
        let g = &self.rows_of;
        self.p.total == p.total
            && self.a.shape() == (n, n)
            && self.c.shape() == (ny, n)
            && self.block.shape() == (BLOCK, p.total + 1)
            && self.used <= BLOCK
            && self.row.len() == p.total
            && g.a.shape() == (n, n)
            && g.p.total == p.total
            && g.z.len() == nu * n * n
            && g.ztmp.len() == nu * n * n
            && g.cat.len() == ny * n
            && g.cattmp.len() == ny * n
            && g.c_rows.len() == ny * n
    }
}

/// Instrumental-variable estimate of (B, D, x₀) for given (A, C): the
/// regressors are filtered from u, the instruments by the same filters from
/// each record's instrument signal (thesis §7.4; the excitation f of a
/// closed loop), θ = (Σ ζφᵀ)⁺ Σ ζy. y may contain NaN at unsampled instants.
///
/// Cost O(N_y·(2n_u n³ + p²)); memory O(p²).
///
/// Errors: as [`estimate_bd`].
pub fn estimate_bd_iv(
    a: &DMatrix<f64>,
    c: &DMatrix<f64>,
    records: &[Record<'_>],
    feedthrough: &Feedthrough,
    x0: InitialState,
) -> Result<BdFit> {
    let (p, scale, c_scaled) = bd_problem(a, c, records, feedthrough, x0, true, false)?;
    let np = p.total;
    let mut g = DMatrix::zeros(np, np);
    let mut gy = DMatrix::zeros(np, 1);
    let rows = stream(a, &c_scaled, &p, records, true, scale, &mut |phi, zeta| {
        if let Some(z) = zeta {
            let zt = z.transpose();
            g += &zt * phi.columns(0, np);
            gy += &zt * phi.columns(np, 1);
        }
        Ok(())
    })?;
    check_rank("B/D instrument matrix", rows, np)?;
    let theta = equilibrated_solve(&g, &gy, "B/D instrument matrix")?;
    Ok(p.unpack(&theta, records.len(), scale.io))
}

/// ‖C Aᵗ‖/‖C‖ below which the initial-state regression stops reading data.
const X0_NEGLIGIBLE: f64 = 1e-17;

/// Least-squares initial state of each record for a fixed model
/// (A, B, C, D): x₀ = argmin Σ‖y(t) − ŷ₀(t) − C Aᵗ x₀‖² with ŷ₀ the
/// zero-state response; rows streamed until C Aᵗ is negligible, or, for
/// an unstable A, until it has grown by [`MAX_REGRESSOR_GROWTH`] (the
/// window that determines x₀; the later rows would swamp it and
/// overflow), O(N n_y n²) flops at most, O(n²) memory beyond the
/// zero-state simulation.
pub fn estimate_x0(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    c: &DMatrix<f64>,
    d: &DMatrix<f64>,
    records: &[Record<'_>],
) -> Result<Vec<DVector<f64>>> {
    lifted_linalg::simd::dispatch(
        #[inline(always)]
        || {
            let n = a.nrows();
            let ny = c.nrows();
            // On the data divided by their scales (model rescaled to match; x₀ is
            // the same).
            let scale = DataScale::of(records).io;
            let (iu, iy) = (1.0 / scale.u, 1.0 / scale.y);
            let (b, c, d) = scale.rescale(b, c, d);
            let mut out = Vec::with_capacity(records.len());
            for rec in records {
                let mut acc = RAccumulator::new(n + 1);
                let mut block = DMatrix::zeros(BLOCK, n + 1);
                let mut used = 0;
                let mut x = DVector::zeros(n);
                let mut cat = c.clone();
                let c_norm = c.norm();
                // Work vectors, reused every sample (the products are the same
                // gemm calls as `&c * &x` etc., so the result is unchanged).
                let nu = rec.u.ncols();
                let mut ut = DVector::zeros(nu);
                let (mut cx, mut du) = (DVector::zeros(ny), DVector::zeros(ny));
                let (mut ax, mut bu) = (DVector::zeros(n), DVector::zeros(n));
                let mut cat_next = DMatrix::zeros(ny, n);
                for t in 0..rec.u.nrows() {
                    for j in 0..nu {
                        ut[j] = rec.u[(t, j)] * iu;
                    }
                    cx.gemm(1.0, &c, &x, 0.0);
                    du.gemm(1.0, &d, &ut, 0.0);
                    for o in 0..ny {
                        let yv = rec.y[(t, o)] * iy;
                        if yv.is_nan() {
                            continue;
                        }
                        for s in 0..n {
                            block[(used, s)] = cat[(o, s)];
                        }
                        block[(used, n)] = yv - (cx[o] + du[o]);
                        used += 1;
                        if used == BLOCK {
                            acc.push_rows(&block)?;
                            used = 0;
                        }
                    }
                    ax.gemm(1.0, a, &x, 0.0);
                    bu.gemm(1.0, &b, &ut, 0.0);
                    for s in 0..n {
                        x[s] = ax[s] + bu[s];
                    }
                    cat_next.gemm(1.0, &cat, a, 0.0);
                    std::mem::swap(&mut cat, &mut cat_next);
                    // Rows with C Aᵗ = 0 carry no information on x₀ (they only add to
                    // the residual norm, which is not used): stop once C Aᵗ is below
                    // rounding level, O(log ε / log ρ(A)) samples instead of N. For
                    // an unstable A stop once C Aᵗ has grown by MAX_REGRESSOR_GROWTH:
                    // later rows would swamp the earlier ones (and overflow), while
                    // x₀ is already determined by the window read so far.
                    let cn = cat.norm();
                    if t > 2 * (n + 1)
                        && (cn <= X0_NEGLIGIBLE * c_norm || cn > MAX_REGRESSOR_GROWTH * c_norm)
                    {
                        break;
                    }
                }
                if used > 0 {
                    acc.push_rows(&block.rows(0, used).into_owned())?;
                }
                let r = acc.r();
                if r.nrows() < n + 1 {
                    out.push(DVector::zeros(n));
                    continue;
                }
                let r11 = r.view((0, 0), (n, n)).into_owned();
                let r12 = r.view((0, n), (n, 1)).into_owned();
                let th = lstsq(&r11, &r12)?;
                out.push(DVector::from_fn(n, |s, _| th[(s, 0)]));
            }
            Ok(out)
        },
    )
}

/// Longest record (samples).
fn longest(records: &[Record<'_>]) -> usize {
    records.iter().map(|r| r.u.nrows()).max().unwrap_or(0)
}

/// Scales the columns of `m` to unit norm; returns the factors 1/‖·‖ (1 for
/// a zero column).
fn unit_columns(m: &mut DMatrix<f64>) -> Vec<f64> {
    m.column_iter_mut()
        .map(|mut col| {
            let c = col.norm();
            if c > 0.0 {
                col /= c;
                1.0 / c
            } else {
                1.0
            }
        })
        .collect()
}

/// Two-sided equilibration E·M·D of `m`: rows scaled to unit norm, then
/// columns; returns (E M D, diag E, diag D) (scale 1 for a zero row or
/// column).
fn equilibrate(m: &DMatrix<f64>) -> (DMatrix<f64>, Vec<f64>, Vec<f64>) {
    let mut t = m.transpose();
    let rs = unit_columns(&mut t);
    let mut e = t.transpose();
    let cs = unit_columns(&mut e);
    (e, rs, cs)
}

/// Numerical rank with the relative tolerance 1e-12 of the regressions.
fn regression_rank(m: &DMatrix<f64>) -> Result<usize> {
    numerical_rank(m, 1e-12)
}

/// θ = D (E M D)⁺ E b for the regression matrix M (R factor or IV normal
/// matrix) after the rank test on the equilibrated E M D
/// ([`equilibrate`]): test and solution do not depend on the units of the
/// parameters or of the instruments. O(p³) for p parameters.
pub(crate) fn equilibrated_solve(
    m: &DMatrix<f64>,
    b: &DMatrix<f64>,
    what: &'static str,
) -> Result<DMatrix<f64>> {
    let (e, rs, cs) = equilibrate(m);
    check_rank(what, regression_rank(&e)?, m.ncols())?;
    let eb = DMatrix::from_fn(b.nrows(), b.ncols(), |i, j| b[(i, j)] * rs[i]);
    let z = lstsq(&e, &eb)?;
    Ok(DMatrix::from_fn(z.nrows(), z.ncols(), |i, j| {
        z[(i, j)] * cs[i]
    }))
}

/// Column-equilibrated rank test of a regressor matrix (each column
/// scaled to unit norm, then the relative tolerance 1e-12).
fn check_regressor_rank(m: &DMatrix<f64>, what: &'static str) -> Result<()> {
    let mut e = m.clone();
    unit_columns(&mut e);
    check_rank(what, regression_rank(&e)?, m.ncols())?;
    Ok(())
}

/// Result of [`structured_state_lstsq`].
#[derive(Debug, Clone, PartialEq)]
pub struct StateFit {
    /// A (n×n).
    pub a: DMatrix<f64>,
    /// B (n×n_u).
    pub b: DMatrix<f64>,
    /// C (n_y×n).
    pub c: DMatrix<f64>,
    /// D (n_y×n_u), exactly zero outside the mask.
    pub d: DMatrix<f64>,
    /// Covariance of the state-equation residuals (n×n), 1/N scaling.
    pub q: DMatrix<f64>,
    /// Covariance of the output-equation residuals (n_y×n_y).
    pub r: DMatrix<f64>,
    /// Cross covariance (n×n_y).
    pub s: DMatrix<f64>,
}

/// Least-squares state-space fit with a structured D (thesis §4.5,
/// eqs. 4.17–4.19 and the normal equations after 4.20): given states x(k)
/// (N+1 rows), inputs u(k) and outputs y(k) (N rows each),
/// [A B] = argmin Σ‖x(k+1) − A x(k) − B u(k)‖², and per output row i
/// [Cᵢ Dᵢ] from only the regressors [x(k); u_j(k) for mask(i, j)] — the
/// masked entries of D are structurally zero (Pitfall 5).
///
/// Cost O(N(n + n_u)²(1 + n_y)); memory O(N(n + n_u)).
///
/// Errors: [`Error::DimensionMismatch`], [`Error::NonFinite`],
/// [`Error::RankDeficient`] when a regressor set is rank deficient.
pub fn structured_state_lstsq(
    x: &DMatrix<f64>,
    u: &DMatrix<f64>,
    y: &DMatrix<f64>,
    d_mask: &DMatrix<bool>,
) -> Result<StateFit> {
    let nn = u.nrows();
    if x.nrows() != nn + 1 || y.nrows() != nn {
        return Err(Error::DimensionMismatch {
            what: "states/inputs/outputs",
            expected: format!("x {} rows, y {nn} rows", nn + 1),
            got: format!("x {} rows, y {} rows", x.nrows(), y.nrows()),
        });
    }
    let (n, nu, ny) = (x.ncols(), u.ncols(), y.ncols());
    if d_mask.shape() != (ny, nu) {
        return Err(Error::DimensionMismatch {
            what: "d_mask",
            expected: format!("{ny}x{nu}"),
            got: format!("{}x{}", d_mask.nrows(), d_mask.ncols()),
        });
    }
    check_data("x", x)?;
    check_data("u", u)?;
    check_data("y", y)?;
    check_rank("state regressor [x; u]", nn, n + nu)?;
    let xk = x.rows(0, nn).into_owned();
    let xk1 = x.rows(1, nn).into_owned();
    let mut z = DMatrix::zeros(nn, n + nu);
    z.columns_mut(0, n).copy_from(&xk);
    z.columns_mut(n, nu).copy_from(u);
    check_regressor_rank(&z, "B/D regressor")?;
    let ab = lstsq(&z, &xk1)?.transpose();
    let a = ab.columns(0, n).into_owned();
    let b = ab.columns(n, nu).into_owned();
    let mut c = DMatrix::zeros(ny, n);
    let mut d = DMatrix::zeros(ny, nu);
    for i in 0..ny {
        let cols: Vec<usize> = (0..nu).filter(|&j| d_mask[(i, j)]).collect();
        let mut zi = DMatrix::zeros(nn, n + cols.len());
        zi.columns_mut(0, n).copy_from(&xk);
        for (t, &j) in cols.iter().enumerate() {
            zi.column_mut(n + t).copy_from(&u.column(j));
        }
        let th = lstsq(
            &zi,
            &DMatrix::from_column_slice(nn, 1, y.column(i).as_slice()),
        )?;
        for s in 0..n {
            c[(i, s)] = th[(s, 0)];
        }
        for (t, &j) in cols.iter().enumerate() {
            d[(i, j)] = th[(n + t, 0)];
        }
    }
    let w = &xk1.transpose() - &a * xk.transpose() - &b * u.transpose();
    let v = &y.transpose() - &c * xk.transpose() - &d * u.transpose();
    let scale = 1.0 / nn as f64;
    Ok(StateFit {
        q: &w * w.transpose() * scale,
        r: &v * v.transpose() * scale,
        s: &w * v.transpose() * scale,
        a,
        b,
        c,
        d,
    })
}

#[cfg(test)]
mod tests;

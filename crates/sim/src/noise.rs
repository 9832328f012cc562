//! Output noise: seeded white noise through a noise model, optionally
//! integrated, scaled to a signal-to-noise ratio.

use lifted_lti::{StateSpace, TransferFunction};
use nalgebra::DMatrix;
use rand::RngExt;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use crate::engine::{Block, StepMap};
use crate::error::{Error, Result};
use crate::model::at_base_period;

/// Definition of the signal-to-noise ratio (spec §0).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SnrDefinition {
    /// SNR = var(noise-free output) / var(noise) (the spec's default).
    #[default]
    Variance,
    /// SNR = std(noise-free output) / std(noise).
    StdRatio,
}

/// How loud the noise is.
#[derive(Debug, Clone, PartialEq)]
pub enum NoiseLevel {
    /// Standard deviation of each white source e_j (one value, or one per
    /// source); the noise is not rescaled.
    Std(Vec<f64>),
    /// Scale the generated noise per output channel, **after** generating
    /// it, so that the realised ratio of the noise-free output to the
    /// noise equals the request on the simulated record (spec §0). One
    /// value for all outputs or one per output.
    Snr {
        /// Requested ratio(s), > 0.
        ratio: Vec<f64>,
        /// Variance ratio (default) or standard-deviation ratio.
        definition: SnrDefinition,
    },
}

/// Output noise v = α ∘ H(q) e (Box–Jenkins: H has its own poles), added to
/// the plant output before it is measured and fed back.
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseSpec {
    /// Noise model H (n_y × n_e), continuous (ZOH at T) or discrete at T.
    /// Default None: white noise, H = I.
    pub model: Option<StateSpace>,
    /// Integrate the filtered noise, v(k) = v(k−1) + (He)(k) (H/(1 − z⁻¹),
    /// the MPC chapter's disturbance model). Default false.
    pub integrated: bool,
    /// Level: absolute std or SNR. Default SNR 10 (variance ratio).
    pub level: NoiseLevel,
    /// Seed of the ChaCha8 generator. Default 0.
    pub seed: u64,
    /// Samples the filter runs before the record starts, so that coloured
    /// noise starts stationary. Default None: ⌈ln(1e-9)/ln ρ⌉ for spectral
    /// radius ρ of the noise model (capped at 100 000); 0 for white or
    /// integrated noise.
    pub warmup: Option<usize>,
}

impl Default for NoiseSpec {
    fn default() -> Self {
        NoiseSpec {
            model: None,
            integrated: false,
            level: NoiseLevel::Snr {
                ratio: vec![10.0],
                definition: SnrDefinition::Variance,
            },
            seed: 0,
            warmup: None,
        }
    }
}

impl NoiseSpec {
    /// White noise at a variance SNR (the same on every output).
    pub fn white_snr(snr: f64, seed: u64) -> Self {
        NoiseSpec {
            level: NoiseLevel::Snr {
                ratio: vec![snr],
                definition: SnrDefinition::Variance,
            },
            seed,
            ..Default::default()
        }
    }

    /// Noise through `model` at SNR `ratio` with the given definition.
    pub fn filtered(model: StateSpace, ratio: f64, definition: SnrDefinition, seed: u64) -> Self {
        NoiseSpec {
            model: Some(model),
            level: NoiseLevel::Snr {
                ratio: vec![ratio],
                definition,
            },
            seed,
            ..Default::default()
        }
    }

    /// A diagonal noise model from one SISO transfer function per output
    /// (all continuous or all discrete at the same period).
    pub fn diagonal_model(filters: &[TransferFunction]) -> Result<StateSpace> {
        let mut it = filters.iter();
        let first = it.next().ok_or(Error::DimensionMismatch {
            what: "noise filters",
            expected: 1,
            got: 0,
        })?;
        let mut acc = first.to_ss()?;
        for f in it {
            acc = lifted_lti::append(&acc, &f.to_ss()?)?;
        }
        Ok(acc)
    }
}

/// The noise generator compiled at the base period.
#[derive(Debug, Clone)]
pub(crate) struct NoiseGen {
    filter: Option<Block>,
    n_e: usize,
    std: Vec<f64>,
    integrated: bool,
    seed: u64,
    warmup: usize,
    pub snr: Option<(Vec<f64>, SnrDefinition)>,
}

impl NoiseGen {
    pub fn new(spec: &NoiseSpec, ny: usize, ts: f64) -> Result<Self> {
        let (filter, n_e, rho) = match &spec.model {
            None => (None, ny, 0.0),
            Some(m) => {
                if m.n_outputs() != ny {
                    return Err(Error::DimensionMismatch {
                        what: "noise model outputs (= plant outputs)",
                        expected: ny,
                        got: m.n_outputs(),
                    });
                }
                let d = at_base_period("noise model", m, ts)?;
                let rho = if d.order() == 0 {
                    0.0
                } else {
                    d.poles()?.iter().map(|p| p.norm()).fold(0.0, f64::max)
                };
                (Some(Block::new(&d)), d.n_inputs(), rho)
            }
        };
        let (std, snr) = match &spec.level {
            NoiseLevel::Std(s) => {
                let s = broadcast(s, n_e, "noise std values")?;
                for (channel, &value) in s.iter().enumerate() {
                    if !(value.is_finite() && value >= 0.0) {
                        return Err(Error::InvalidNoiseStd { channel, value });
                    }
                }
                (s, None)
            }
            NoiseLevel::Snr { ratio, definition } => {
                let r = broadcast(ratio, ny, "SNR values")?;
                for (channel, &value) in r.iter().enumerate() {
                    if !(value.is_finite() && value > 0.0) {
                        return Err(Error::InvalidSnr { channel, value });
                    }
                }
                (vec![1.0; n_e], Some((r, *definition)))
            }
        };
        let warmup = match spec.warmup {
            Some(w) => w,
            None if spec.integrated || rho == 0.0 => 0,
            None if rho >= 1.0 => 0,
            None => ((1e-9f64).ln() / rho.ln()).ceil().min(100_000.0) as usize,
        };
        Ok(NoiseGen {
            filter,
            n_e,
            std,
            integrated: spec.integrated,
            seed: spec.seed,
            warmup,
            snr,
        })
    }

    /// Generates the raw (unscaled by SNR) noise, len × ny, column-major.
    /// Draw order: for each sample (warm-up first), e_0 … e_{n_e−1}.
    ///
    /// The normals are drawn in blocks of [`BLOCK`] samples, then filtered
    /// by one fused product per sample with the stacked matrix
    /// [x(k+1); v(k)] = [A B; C D][x(k); e(k)] (the simulator's fused step:
    /// FMAs, state and input columns in separate partial sums), then written
    /// channel by channel. Equal to the block-by-block filter up to rounding.
    /// O((warm-up + len) · (n_x + n_y)(n_x + n_e)).
    #[cfg(test)]
    pub fn generate(&self, len: usize, ny: usize) -> DMatrix<f64> {
        let mut out = DMatrix::zeros(len, ny);
        self.generate_into(&mut out);
        out
    }

    /// [`NoiseGen::generate`] into `out` (len × ny, every entry overwritten).
    pub fn generate_into(&self, out: &mut DMatrix<f64>) {
        let (len, ny) = out.shape();
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let os = out.as_mut_slice();
        let ne = self.n_e;
        let total = self.warmup + len;
        // [A B; C D] from the block applied to unit vectors
        let map = self.filter.as_ref().map(|f| {
            let nx = f.n;
            let (mut x, mut e) = (vec![0.0; nx], vec![0.0; ne]);
            let (mut xn, mut v) = (vec![0.0; nx], vec![0.0; ny]);
            let cols: Vec<Vec<f64>> = (0..nx + ne)
                .map(|c| {
                    x.fill(0.0);
                    e.fill(0.0);
                    if c < nx {
                        x[c] = 1.0;
                    } else {
                        e[c - nx] = 1.0;
                    }
                    f.cx(&x, &mut v);
                    f.add_du(&e, &mut v);
                    f.update(&x, &e, &mut xn);
                    [xn.as_slice(), v.as_slice()].concat()
                })
                .collect();
            StepMap::new(nx, ne, &cols)
        });
        let (rows, nx) = map.as_ref().map_or((ne, 0), |m| (m.rows, m.states));
        // the block's normals source by source (source i at i · BLOCK + b)
        let mut e = vec![0.0; BLOCK * ne];
        // row 0: the filter state entering the block; row b + 1: sample b
        let mut hist = vec![0.0; (BLOCK + 1) * rows];
        let mut acc = Vec::new();
        let mut integ = vec![0.0; ny];
        let mut k0 = 0;
        while k0 < total {
            let nb = BLOCK.min(total - k0);
            for b in 0..nb {
                for (i, sd) in self.std.iter().enumerate() {
                    let z: f64 = rng.sample(StandardNormal);
                    e[i * BLOCK + b] = sd * z;
                }
            }
            if let Some(map) = &map {
                map.run(&mut hist, &e, BLOCK, nb, &mut acc);
            }
            // samples of the block inside the record (after the warm-up)
            let skip = self.warmup.saturating_sub(k0).min(nb);
            let kk0 = (k0 + skip).saturating_sub(self.warmup);
            let count = nb - skip;
            for (j, integ) in integ.iter_mut().enumerate().take(ny) {
                if count == 0 {
                    break;
                }
                let dst = &mut os[j * len + kk0..j * len + kk0 + count];
                // v_j(b): filter output row nx + j of hist row b + 1, or e_j(b)
                let src = match &map {
                    Some(_) => hist[(skip + 1) * rows + nx + j..].iter().step_by(rows),
                    None => e[j * BLOCK + skip..].iter().step_by(1),
                };
                if self.integrated {
                    for (d, &v) in dst.iter_mut().zip(src) {
                        *integ += v;
                        *d = *integ;
                    }
                } else {
                    for (d, &v) in dst.iter_mut().zip(src) {
                        *d = v;
                    }
                }
            }
            if map.is_some() {
                hist.copy_within(nb * rows..nb * rows + nx, 0);
            }
            k0 += nb;
        }
    }

    /// The block-by-block generator (the previous implementation), kept to
    /// test [`NoiseGen::generate`] against.
    #[cfg(test)]
    pub fn generate_reference(&self, len: usize, ny: usize) -> DMatrix<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let mut out = DMatrix::zeros(len, ny);
        let os = out.as_mut_slice();
        let mut e = vec![0.0; self.n_e];
        let mut v = vec![0.0; ny];
        let mut acc = vec![0.0; ny];
        let nx = self.filter.as_ref().map_or(0, |f| f.n);
        let mut x = vec![0.0; nx];
        let mut xn = vec![0.0; nx];
        for k in 0..self.warmup + len {
            for (ej, sj) in e.iter_mut().zip(&self.std) {
                let z: f64 = rng.sample(StandardNormal);
                *ej = sj * z;
            }
            match &self.filter {
                None => v.copy_from_slice(&e),
                Some(f) => {
                    f.cx(&x, &mut v);
                    f.add_du(&e, &mut v);
                    f.update(&x, &e, &mut xn);
                    std::mem::swap(&mut x, &mut xn);
                }
            }
            if k < self.warmup {
                continue;
            }
            let kk = k - self.warmup;
            for j in 0..ny {
                let val = if self.integrated {
                    acc[j] += v[j];
                    acc[j]
                } else {
                    v[j]
                };
                os[j * len + kk] = val;
            }
        }
        out
    }
}

/// Samples per block of drawn normals (stays in L1 with the filter state).
const BLOCK: usize = 256;

fn broadcast(v: &[f64], n: usize, what: &'static str) -> Result<Vec<f64>> {
    match v.len() {
        1 => Ok(vec![v[0]; n]),
        l if l == n => Ok(v.to_vec()),
        l => Err(Error::DimensionMismatch {
            what,
            expected: n,
            got: l,
        }),
    }
}

/// Sample variance (1/N, about the mean) of a column.
/// Variance of x[offset], x[offset + step], … (population form; 0 when empty).
pub(crate) fn variance_every(x: &[f64], step: usize, offset: usize) -> f64 {
    let pick = || x.iter().skip(offset).step_by(step.max(1));
    let n = pick().count();
    if n == 0 {
        return 0.0;
    }
    let mean = pick().sum::<f64>() / n as f64;
    pick().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n as f64
}

/// Per-channel scale α so that the realised SNR equals the request.
pub(crate) fn snr_scale(
    clean: &DMatrix<f64>,
    raw: &DMatrix<f64>,
    ratio: &[f64],
    def: SnrDefinition,
    samples: Option<&[(usize, usize)]>,
) -> Result<Vec<f64>> {
    (0..clean.ncols())
        .map(|j| {
            let (step, offset) = samples.map_or((1, 0), |s| s[j]);
            let vs = variance_every(clean.column(j).as_slice(), step, offset);
            let vn = variance_every(raw.column(j).as_slice(), step, offset);
            if vs.is_nan() || vs <= 0.0 {
                return Err(Error::ZeroSignalVariance { channel: j });
            }
            if vn.is_nan() || vn <= 0.0 {
                return Err(Error::ZeroNoiseVariance { channel: j });
            }
            // var: vs / (α² vn) = r ; std: sqrt(vs) / (α sqrt(vn)) = r
            Ok(match def {
                SnrDefinition::Variance => (vs / (ratio[j] * vn)).sqrt(),
                SnrDefinition::StdRatio => vs.sqrt() / (ratio[j] * vn.sqrt()),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn snr_scale_is_exact_for_both_definitions() {
        let clean = DMatrix::from_fn(1000, 1, |k, _| (k as f64 * 0.1).sin() * 3.0);
        let raw = DMatrix::from_fn(1000, 1, |k, _| ((k * 7919) % 101) as f64 / 50.0 - 1.0);
        let vs = variance_every(clean.column(0).as_slice(), 1, 0);
        let vn = variance_every(raw.column(0).as_slice(), 1, 0);
        let a = snr_scale(&clean, &raw, &[4.0], SnrDefinition::Variance, None).unwrap()[0];
        assert!((vs / (a * a * vn) - 4.0).abs() < 1e-12);
        let a = snr_scale(&clean, &raw, &[4.0], SnrDefinition::StdRatio, None).unwrap()[0];
        assert!((vs.sqrt() / (a * vn.sqrt()) - 4.0).abs() < 1e-12);
        let zero = DMatrix::zeros(1000, 1);
        assert!(matches!(
            snr_scale(&zero, &raw, &[4.0], SnrDefinition::Variance, None),
            Err(Error::ZeroSignalVariance { channel: 0 })
        ));
        assert!(matches!(
            snr_scale(&clean, &zero, &[4.0], SnrDefinition::Variance, None),
            Err(Error::ZeroNoiseVariance { channel: 0 })
        ));
    }

    #[test]
    fn broadcast_and_warmup() {
        assert_eq!(broadcast(&[2.0], 3, "x").unwrap(), vec![2.0; 3]);
        assert!(matches!(
            broadcast(&[1.0, 2.0], 3, "x"),
            Err(Error::DimensionMismatch { .. })
        ));
        let ar = lifted_lti::TransferFunction::from_coeffs(&[1.0, 0.0], &[1.0, -0.5], Some(1.0))
            .unwrap()
            .to_ss()
            .unwrap();
        let g = NoiseGen::new(
            &NoiseSpec {
                model: Some(ar),
                ..Default::default()
            },
            1,
            1.0,
        )
        .unwrap();
        // ⌈ln 1e-9 / ln 0.5⌉ = 30
        assert_eq!(g.warmup, 30);
        let w = NoiseGen::new(&NoiseSpec::default(), 2, 1.0).unwrap();
        assert_eq!(w.warmup, 0);
    }

    #[test]
    fn generate_equals_the_block_by_block_filter() {
        let h1 = lifted_lti::TransferFunction::from_coeffs(&[0.1, 0.05], &[1.0, -0.9], Some(1.0))
            .unwrap();
        let h2 = lifted_lti::TransferFunction::from_coeffs(&[1.0], &[1.0, -1.2, 0.5], Some(1.0))
            .unwrap();
        let h = NoiseSpec::diagonal_model(&[h1, h2]).unwrap();
        // an 18-state coupled model with three sources (rows 20: the
        // run-time-size step)
        let big = StateSpace::new(
            DMatrix::from_fn(18, 18, |i, j| match j as i64 - i as i64 {
                0 => 0.5,
                1 => 0.1,
                _ => 0.0,
            }),
            DMatrix::from_fn(18, 3, |i, j| ((i + 2 * j) % 5) as f64 * 0.1),
            DMatrix::from_fn(2, 18, |i, j| if (i + j) % 3 == 0 { 1.0 } else { 0.2 }),
            DMatrix::from_fn(2, 3, |i, j| if i == j { 1.0 } else { 0.0 }),
            Some(1.0),
        )
        .unwrap();
        for (model, integrated, std, warmup) in [
            (None, false, vec![1.0, 0.5], 300),
            (None, true, vec![2.0], 0),
            (Some(h.clone()), false, vec![1.0, 3.0], 256),
            (Some(h), true, vec![0.7], 300),
            (Some(big.clone()), false, vec![1.0, 0.5, 2.0], 0),
            (Some(big), true, vec![0.3], 513),
        ] {
            let g = NoiseGen::new(
                &NoiseSpec {
                    model,
                    integrated,
                    level: NoiseLevel::Std(std),
                    seed: 9,
                    warmup: Some(warmup),
                },
                2,
                1.0,
            )
            .unwrap();
            let (fast, slow) = (g.generate(1000, 2), g.generate_reference(1000, 2));
            let scale = slow.iter().fold(1.0f64, |m, v| m.max(v.abs()));
            let diff = fast
                .iter()
                .zip(slow.iter())
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
            assert!(diff <= 1e-12 * scale, "diff {diff} scale {scale}");
        }
    }
}

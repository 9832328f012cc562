//! What the (B, D, x₀) regression estimates and takes: the feedthrough's
//! free entries and the initial states (option types of
//! [`crate::SubspaceOptions`]), the records, the parameter bookkeeping, the
//! result and the data scales. Kept apart from the kernels (`regress`,
//! `modal`, `order`) and the options so that none of them imports another
//! upward: each imports these types from here (no import loop).

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::numerics::{Scale, pow4_scale};

/// Which entries of the feedthrough D are estimated.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub enum Feedthrough {
    /// All entries free.
    #[default]
    Free,
    /// D ≡ 0 (strictly proper model).
    Zero,
    /// Entry (i, j) is estimated iff `mask[(i, j)]`; the others are zero
    /// (causal lifted D̄ of thesis eq. 4.17, spec A3.5).
    Mask(DMatrix<bool>),
}

impl Feedthrough {
    /// The n_y×n_u mask of free entries.
    pub fn mask(&self, ny: usize, nu: usize) -> Result<DMatrix<bool>> {
        match self {
            Feedthrough::Free => Ok(DMatrix::from_element(ny, nu, true)),
            Feedthrough::Zero => Ok(DMatrix::from_element(ny, nu, false)),
            Feedthrough::Mask(m) => {
                if m.shape() != (ny, nu) {
                    return Err(Error::DimensionMismatch {
                        what: "feedthrough mask",
                        expected: format!("{ny}x{nu}"),
                        got: format!("{}x{}", m.nrows(), m.ncols()),
                    });
                }
                Ok(m.clone())
            }
        }
    }
}

/// How the initial state of each record is treated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum InitialState {
    /// x₀ = 0 (zero-initial-state simulation).
    Zero,
    /// x₀ estimated jointly with B and D, one per record.
    #[default]
    Estimate,
}

/// Result of [`crate::estimate_bd`] / [`crate::estimate_bd_iv`].
#[derive(Debug, Clone, PartialEq)]
pub struct BdFit {
    /// Input matrix B (n×n_u).
    pub b: DMatrix<f64>,
    /// Feedthrough D (n_y×n_u), zero outside the mask.
    pub d: DMatrix<f64>,
    /// Initial state per record (zeros when not estimated).
    pub x0: Vec<DVector<f64>>,
    /// Constant output offset per record (n_y each; zeros unless estimated
    /// by [`crate::estimate_bd_with_offsets`]): y = c + G u + C Aᵗ x₀.
    pub offsets: Vec<DVector<f64>>,
}

/// One record for [`crate::estimate_bd`]: input u (N×n_u), output y (N×n_y, NaN
/// allowed at unsampled instants), optional instrument (N×n_u, IV only).
#[derive(Debug, Clone, Copy)]
pub struct Record<'a> {
    /// Input, one row per sample.
    pub u: &'a DMatrix<f64>,
    /// Output, one row per sample; NaN marks an unsampled instant.
    pub y: &'a DMatrix<f64>,
    /// Instrument signal of the same shape as `u` (closed loop); `None`
    /// uses `u` itself.
    pub instrument: Option<&'a DMatrix<f64>>,
}

/// Parameter bookkeeping for θ = (vec B, D entries, x₀ per record).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(crate) struct Params {
    pub(crate) n: usize,
    pub(crate) nu: usize,
    pub(crate) ny: usize,
    pub(crate) d_index: DMatrix<Option<usize>>,
    pub(crate) x0_offset: Option<usize>,
    /// Start of the constant output offsets (n_y per record), if estimated.
    pub(crate) c_offset: Option<usize>,
    pub(crate) total: usize,
}

impl Params {
    pub(crate) fn new(
        n: usize,
        nu: usize,
        ny: usize,
        mask: &DMatrix<bool>,
        x0: InitialState,
        records: usize,
        offsets: bool,
    ) -> Self {
        let mut idx = n * nu;
        let mut d_index = DMatrix::from_element(ny, nu, None);
        for o in 0..ny {
            for j in 0..nu {
                if mask[(o, j)] {
                    d_index[(o, j)] = Some(idx);
                    idx += 1;
                }
            }
        }
        let x0_offset = match x0 {
            InitialState::Estimate => {
                let off = idx;
                idx += n * records;
                Some(off)
            }
            InitialState::Zero => None,
        };
        let c_offset = offsets.then(|| {
            let off = idx;
            idx += ny * records;
            off
        });
        Params {
            n,
            nu,
            ny,
            d_index,
            x0_offset,
            c_offset,
            total: idx,
        }
    }

    /// θ of the data divided by `scale` → (B, D, x₀) in original units.
    pub(crate) fn unpack(&self, theta: &DMatrix<f64>, records: usize, scale: Scale) -> BdFit {
        let (n, nu, ny) = (self.n, self.nu, self.ny);
        let b = DMatrix::from_fn(n, nu, |s, j| theta[(j * n + s, 0)]);
        let d = DMatrix::from_fn(ny, nu, |o, j| {
            self.d_index[(o, j)].map_or(0.0, |i| theta[(i, 0)])
        });
        let x0 = (0..records)
            .map(|e| match self.x0_offset {
                Some(off) => DVector::from_fn(n, |s, _| theta[(off + e * n + s, 0)]),
                None => DVector::zeros(n),
            })
            .collect();
        let offsets = (0..records)
            .map(|e| match self.c_offset {
                Some(off) => DVector::from_fn(ny, |o, _| theta[(off + e * ny + o, 0)] * scale.y),
                None => DVector::zeros(ny),
            })
            .collect();
        let (b, _, d) = scale.unscale(b, DMatrix::zeros(0, n), d);
        BdFit { b, d, x0, offsets }
    }
}

/// Scales (powers of 4 near the RMS, [`pow4_scale`](crate::numerics::pow4_scale)) of the inputs,
/// outputs (finite entries) and instruments of the records: the
/// regressions run on the data divided by them, so that neither the data's
/// magnitude (overflow of the squared regressors) nor the ratio of output
/// to input units (relative rank tolerance) matters.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub(crate) struct DataScale {
    pub(crate) io: Scale,
    pub(crate) z: f64,
}

impl DataScale {
    /// The scales of inputs and outputs (no instrument).
    pub(crate) fn with_io(io: Scale) -> Self {
        DataScale { io, z: 1.0 }
    }

    pub(crate) fn of(records: &[Record<'_>]) -> Self {
        let us: Vec<&DMatrix<f64>> = records.iter().map(|r| r.u).collect();
        let ys: Vec<&DMatrix<f64>> = records.iter().map(|r| r.y).collect();
        let zs: Vec<&DMatrix<f64>> = records.iter().filter_map(|r| r.instrument).collect();
        DataScale {
            io: Scale {
                u: pow4_scale(&us),
                y: pow4_scale(&ys),
            },
            z: pow4_scale(&zs),
        }
    }
}

//! Preprocessing: offsets removed from the records (the operating point
//! stored with the model), and a record less an operating point.

use lifted_lti::data::Detrend as LtiDetrend;
use lifted_lti::{Dataset, OperatingPoint, PolyModel, StateSpace};
use nalgebra::DMatrix;

use crate::error::{Context, Error, Result};
use crate::options::Detrend;

/// The pooled per-channel means of the records (the operating point stored
/// with the model) and the records detrended per `detrend`.
pub fn detrend_sets(
    sets: Vec<Dataset>,
    detrend: Detrend,
) -> Result<(Option<OperatingPoint>, Vec<Dataset>)> {
    if detrend == Detrend::None {
        return Ok((None, sets));
    }
    let refs: Vec<&Dataset> = sets.iter().collect();
    detrended(&refs, detrend)
}

/// [`detrend_sets`] of borrowed records: the detrended copies (one copy of
/// the data; the records themselves for [`Detrend::None`], copied).
pub(crate) fn detrended(
    sets: &[&Dataset],
    detrend: Detrend,
) -> Result<(Option<OperatingPoint>, Vec<Dataset>)> {
    let kind = match detrend {
        Detrend::None => return Ok((None, sets.iter().map(|d| (*d).clone()).collect())),
        Detrend::Mean => LtiDetrend::Constant,
        Detrend::Linear => LtiDetrend::Linear,
    };
    let us: Vec<&DMatrix<f64>> = sets.iter().map(|d| d.u()).collect();
    let ys: Vec<&DMatrix<f64>> = sets.iter().map(|d| d.y()).collect();
    let op = OperatingPoint::means(&us, &ys).ctx("detrend")?;
    let out = sets
        .iter()
        .map(|d| d.detrend(kind).ctx("detrend"))
        .collect::<Result<_>>()?;
    Ok((Some(op), out))
}

/// The operating point a model file states: the one the identification
/// used, or, for records taken as they are (`Detrend::None`), the origin —
/// so that `validate` and the studio, which remove a record's own means
/// from a model without one, score the model on the data it relates
/// (a `--detrend none` model of the dryer record scored 91.9 % that way
/// against 85.4 % on the data as they are).
pub(crate) fn stated_operating_point(
    op: Option<OperatingPoint>,
    detrend: Detrend,
    model: &StateSpace,
) -> Result<Option<OperatingPoint>> {
    match (op, detrend) {
        (None, Detrend::None) => Ok(Some(
            OperatingPoint::new(vec![0.0; model.n_inputs()], vec![0.0; model.n_outputs()])
                .ctx("operating point")?,
        )),
        (op, _) => Ok(op),
    }
}

/// A record less an operating point (the data the model's deviations are
/// fitted to), or the record itself.
pub fn deviations(data: &Dataset, op: Option<&OperatingPoint>) -> Result<Dataset> {
    match op {
        Some(op) => {
            let neg = |v: &[f64]| v.iter().map(|x| -x).collect::<Vec<f64>>();
            data.shifted(&neg(&op.u0), &neg(&op.y0))
                .ctx("operating point")
        }
        None => Ok(data.clone()),
    }
}

/// Per-channel scales: the standard deviation of each input and output
/// over the first [`SCALE_ROWS`] rows of the first record (measured
/// samples only; 1 for a constant channel). Every route but the q-Markov
/// Cover identifies on the channels divided by them and the model is
/// brought back to the data's units
/// ([`ChannelScales::model`]), so the result does not depend on the units
/// a channel is logged in: N4SID's and MOESP's projections weight the
/// outputs by their units, and a 3×3 evaporator record with channels in
/// units 1e-7 … 1e6 apart got order 2 and validation fits 19/1/47 % where
/// the same record got order 8 and 48/58/41 %.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelScales {
    /// Input scales s_u.
    pub u: Vec<f64>,
    /// Output scales s_y.
    pub y: Vec<f64>,
}

/// Rows of the first record the channel scales are taken from
/// ([`ChannelScales::of`]): the streamed route knows them after its first
/// blocks, before it compresses anything, and the in-memory routes take
/// the same rows so that both give the same model (and so do the sharded
/// identifications of the Python package's `lifted.dask`).
pub const SCALE_ROWS: usize = 10_000;

impl ChannelScales {
    /// The scales of `sets`: the standard deviations over the first
    /// [`SCALE_ROWS`] rows of the first record (all of it when shorter).
    /// O(min(N, SCALE_ROWS) (n_u + n_y)).
    pub fn of(sets: &[Dataset]) -> Self {
        match sets.first() {
            Some(d) => {
                let rows = d.len().min(SCALE_ROWS);
                Self::of_rows(&d.u().rows(0, rows), &d.y().rows(0, rows))
            }
            None => ChannelScales {
                u: Vec::new(),
                y: Vec::new(),
            },
        }
    }

    /// The standard deviation of each column of `u` and `y` (finite
    /// values only; 1 for a constant or empty column).
    pub fn of_rows<S1, S2>(
        u: &nalgebra::Matrix<f64, nalgebra::Dyn, nalgebra::Dyn, S1>,
        y: &nalgebra::Matrix<f64, nalgebra::Dyn, nalgebra::Dyn, S2>,
    ) -> Self
    where
        S1: nalgebra::storage::Storage<f64, nalgebra::Dyn, nalgebra::Dyn>,
        S2: nalgebra::storage::Storage<f64, nalgebra::Dyn, nalgebra::Dyn>,
    {
        use lifted_lti::data::channel_scale;
        ChannelScales {
            u: (0..u.ncols())
                .map(|c| channel_scale(u.column(c).iter()))
                .collect(),
            y: (0..y.ncols())
                .map(|c| channel_scale(y.column(c).iter()))
                .collect(),
        }
    }

    /// Blocks (u, y) with every channel divided by its scale.
    pub fn apply_block(&self, u: &DMatrix<f64>, y: &DMatrix<f64>) -> (DMatrix<f64>, DMatrix<f64>) {
        let (mut su, mut sy) = (DMatrix::zeros(0, 0), DMatrix::zeros(0, 0));
        self.apply_block_into(u, y, &mut su, &mut sy);
        (su, sy)
    }

    /// [`ChannelScales::apply_block`] into `su`, `sy` (resized when their
    /// shapes differ, else reused: no allocation from block to block of a
    /// stream). O(rows (n_u + n_y)).
    pub fn apply_block_into(
        &self,
        u: &DMatrix<f64>,
        y: &DMatrix<f64>,
        su: &mut DMatrix<f64>,
        sy: &mut DMatrix<f64>,
    ) {
        for (from, to, scales) in [(u, &mut *su, &self.u), (y, &mut *sy, &self.y)] {
            if to.shape() != from.shape() {
                *to = DMatrix::zeros(from.nrows(), from.ncols());
            }
            // Column slices (contiguous: the loops vectorise).
            let rows = from.nrows().max(1);
            let cols = to.as_mut_slice().chunks_exact_mut(rows);
            for ((t, f), s) in cols.zip(from.as_slice().chunks_exact(rows)).zip(scales) {
                for (t, v) in t.iter_mut().zip(f) {
                    *t = v / s;
                }
            }
        }
    }

    /// [`ChannelScales::apply`] on a record the caller gives up: divided
    /// in place, no copy. O(N (n_u + n_y)).
    pub fn apply_owned(&self, d: Dataset) -> Result<Dataset> {
        let (ts, mut u, mut y, inputs, outputs) = d.into_parts();
        for (c, s) in self.u.iter().enumerate() {
            u.column_mut(c).iter_mut().for_each(|v| *v /= s);
        }
        for (c, s) in self.y.iter().enumerate() {
            y.column_mut(c).iter_mut().for_each(|v| *v /= s);
        }
        Dataset::new(ts, u, y, inputs, outputs).ctx("channel scaling")
    }

    /// The record with every channel divided by its scale (holds and
    /// output sampling kept). O(N (n_u + n_y)).
    pub fn apply(&self, d: &Dataset) -> Result<Dataset> {
        let (u, y) = self.apply_block(d.u(), d.y());
        Dataset::new(d.ts(), u, y, d.inputs().to_vec(), d.outputs().to_vec()).ctx("channel scaling")
    }

    /// A model of the scaled channels in the data's units: B S_u⁻¹,
    /// S_y C, S_y D S_u⁻¹ (A and the state unchanged).
    pub fn model(&self, m: &StateSpace) -> Result<StateSpace> {
        let (mut b, mut c, mut d) = (m.b().clone(), m.c().clone(), m.d().clone());
        for (j, s) in self.u.iter().enumerate() {
            b.column_mut(j).iter_mut().for_each(|v| *v /= s);
            d.column_mut(j).iter_mut().for_each(|v| *v /= s);
        }
        for (o, s) in self.y.iter().enumerate() {
            c.row_mut(o).iter_mut().for_each(|v| *v *= s);
            d.row_mut(o).iter_mut().for_each(|v| *v *= s);
        }
        StateSpace::new(m.a().clone(), b, c, d, m.ts()).ctx("channel scaling")
    }

    /// The covariance of a state-space model's entries on the scaled
    /// channels in the data's units: θ = [vec A; vec B; vec C; vec D]
    /// moves as [`model`](Self::model) moves the model (B_rj ÷ s_uj,
    /// C_or × s_yo, D_oj × s_yo / s_uj, A unchanged), so P ← S P S with
    /// S the diagonal of those factors. O(L²).
    pub fn ss_covariance(
        &self,
        cov: &lifted_lti::SsCovariance,
        m: &StateSpace,
    ) -> Result<lifted_lti::SsCovariance> {
        let (n, nu, ny) = (m.order(), m.n_inputs(), m.n_outputs());
        let mut f = Vec::with_capacity(cov.matrix().nrows());
        f.extend(std::iter::repeat_n(1.0, n * n));
        for j in 0..nu {
            f.extend(std::iter::repeat_n(1.0 / self.u[j], n));
        }
        for _ in 0..n {
            f.extend(self.y.iter().copied());
        }
        for j in 0..nu {
            f.extend(self.y.iter().map(|s| s / self.u[j]));
        }
        let p = cov.matrix();
        if f.len() != p.nrows() {
            return Err(crate::Error::Data(format!(
                "the covariance has {} entries, the model {}",
                p.nrows(),
                f.len()
            )));
        }
        let scaled =
            nalgebra::DMatrix::from_fn(p.nrows(), p.ncols(), |i, j| f[i] * p[(i, j)] * f[j]);
        lifted_lti::SsCovariance::new(n, nu, ny, scaled).ctx("the covariance in the data's units")
    }

    /// A polynomial model of the scaled channels in the data's units: with
    /// y' = y/s_y and u' = u/s_u, A_ij ← A_ij s_yi/s_yj, B_ik ← B_ik
    /// s_yi/s_uk (C, D, F unchanged: A_ii stays monic), Λ_ij ← Λ_ij s_yi
    /// s_yj, and the parameter covariance scaled by the same factors. O(r²)
    /// for r parameters.
    pub fn poly(&self, p: &PolyModel) -> Result<PolyModel> {
        let mut q = p.polynomials();
        let (sy, su) = (&self.y, &self.u);
        let mut factors = Vec::with_capacity(p.n_parameters());
        for (i, row) in q.a.iter_mut().flatten().enumerate() {
            for (j, poly) in row.iter_mut().enumerate() {
                let f = sy[i] / sy[j];
                poly.iter_mut().for_each(|v| *v *= f);
            }
        }
        for (i, row) in q.b.iter_mut().enumerate() {
            for (k, poly) in row.iter_mut().enumerate() {
                let f = sy[i] / su[k];
                poly.iter_mut().for_each(|v| *v *= f);
            }
        }
        // The parameters' factors, in PolyModel::parameters' order.
        for i in 0..sy.len() {
            for j in 0..sy.len() {
                factors.extend(std::iter::repeat_n(
                    sy[i] / sy[j],
                    p.a(i, j).len().saturating_sub(1),
                ));
            }
            for (k, s) in su.iter().enumerate() {
                factors.extend(std::iter::repeat_n(sy[i] / s, p.b(i, k).len()));
            }
            factors.extend(std::iter::repeat_n(1.0, p.c(i).len().saturating_sub(1)));
            factors.extend(std::iter::repeat_n(1.0, p.d(i).len().saturating_sub(1)));
            for k in 0..su.len() {
                factors.extend(std::iter::repeat_n(1.0, p.f(i, k).len().saturating_sub(1)));
            }
        }
        let lambda = DMatrix::from_fn(sy.len(), sy.len(), |i, j| {
            p.noise_variance()[(i, j)] * sy[i] * sy[j]
        });
        let mut out = PolyModel::new(q, p.ts())
            .ctx("channel scaling")?
            .with_noise_variance(&lambda)
            .ctx("channel scaling")?;
        if let Some(cov) = p.covariance() {
            let n = factors.len();
            // (The product of the factors first: the result stays exactly symmetric.)
            let scaled = DMatrix::from_fn(n, n, |r, c| cov[(r, c)] * (factors[r] * factors[c]));
            out = out.with_covariance(&scaled).ctx("channel scaling")?;
        }
        if let Some(names) = p.input_names() {
            out = out
                .with_input_names(names.to_vec())
                .ctx("channel scaling")?;
        }
        if let Some(names) = p.output_names() {
            out = out
                .with_output_names(names.to_vec())
                .ctx("channel scaling")?;
        }
        Ok(out)
    }

    /// A lifted model of the scaled channels in the data's units: lifted
    /// input j is channel `inputs[j]` of the record, lifted output i
    /// channel `outputs[i]` (`RouteDetails::lifted_channels`).
    pub fn lifted_model(
        &self,
        m: &StateSpace,
        inputs: &[usize],
        outputs: &[usize],
    ) -> Result<StateSpace> {
        let (mut b, mut c, mut d) = (m.b().clone(), m.c().clone(), m.d().clone());
        let su = |j: usize| inputs.get(j).and_then(|&c| self.u.get(c)).copied();
        let sy = |i: usize| outputs.get(i).and_then(|&c| self.y.get(c)).copied();
        for j in 0..b.ncols() {
            let s = su(j).ok_or_else(|| Error::Data(format!("lifted input {j} has no channel")))?;
            b.column_mut(j).iter_mut().for_each(|v| *v /= s);
            d.column_mut(j).iter_mut().for_each(|v| *v /= s);
        }
        for i in 0..c.nrows() {
            let s =
                sy(i).ok_or_else(|| Error::Data(format!("lifted output {i} has no channel")))?;
            c.row_mut(i).iter_mut().for_each(|v| *v *= s);
            d.row_mut(i).iter_mut().for_each(|v| *v *= s);
        }
        StateSpace::new(m.a().clone(), b, c, d, m.ts()).ctx("channel scaling")
    }

    /// A Kalman gain of the scaled outputs in the data's units: K S_y⁻¹.
    pub fn gain(&self, k: &DMatrix<f64>) -> DMatrix<f64> {
        let mut k = k.clone();
        for (o, s) in self.y.iter().enumerate() {
            k.column_mut(o).iter_mut().for_each(|v| *v /= s);
        }
        k
    }

    /// An operating point of the scaled channels in the data's units.
    pub fn operating_point(&self, op: &OperatingPoint) -> OperatingPoint {
        OperatingPoint {
            u0: op.u0.iter().zip(&self.u).map(|(v, s)| v * s).collect(),
            y0: op.y0.iter().zip(&self.y).map(|(v, s)| v * s).collect(),
        }
    }
}

//! The uncertainty of a state-space model's responses from the covariance
//! of its entries (issue 49): first-order propagation, the "delta method"
//! of Ljung 1999, §9.4, eq. (9.53), as for a [`crate::PolyModel`].
//!
//! θ = [vec A; vec B; vec C; vec D] (each matrix column by column) and
//! P = Cov θ, an L × L matrix with L = n² + n n_u + n_y n + n_y n_u. P is
//! singular in the free parametrisation: the similarity transformations
//! x → T x move θ without changing any response, and an estimator in
//! local coordinates (`lifted_pem::state_space_covariance`) gives them no
//! variance. The responses' σ need no inverse of P: σ² = ∇gᵀ P ∇g along θ,
//! the gradient by central differences (the step of
//! [`crate::PolyModel::freqresp_std`]). Cost: 2L responses, O(L · len(ω) ·
//! n³) for the frequency response, O(L · samples · n²) for the steps, and
//! O(L²) per response sample for the quadratic form.

use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::polymodel::FreqStd;
use crate::ss::StateSpace;

/// One frequency response (an n_y × n_u matrix per frequency).
type Responses = Vec<DMatrix<Complex64>>;

/// The covariance of a state-space model's entries θ = [vec A; vec B;
/// vec C; vec D] (module docs), for a model of `order` states, `inputs`
/// inputs and `outputs` outputs. JSON (serde): `{"order", "inputs",
/// "outputs", "matrix": [[…], …]}` (rows of P).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "SsCovarianceRepr", into = "SsCovarianceRepr")]
pub struct SsCovariance {
    order: usize,
    inputs: usize,
    outputs: usize,
    matrix: DMatrix<f64>,
}

#[derive(Serialize, Deserialize)]
struct SsCovarianceRepr {
    order: usize,
    inputs: usize,
    outputs: usize,
    matrix: Vec<Vec<f64>>,
}

impl TryFrom<SsCovarianceRepr> for SsCovariance {
    type Error = Error;
    fn try_from(r: SsCovarianceRepr) -> Result<Self> {
        let l = parameter_count(r.order, r.inputs, r.outputs);
        if r.matrix.len() != l || r.matrix.iter().any(|row| row.len() != l) {
            return Err(Error::DimensionMismatch {
                what: "state-space covariance",
                expected: format!("{l}x{l}"),
                got: format!(
                    "{} rows of {:?}",
                    r.matrix.len(),
                    r.matrix.first().map(Vec::len)
                ),
            });
        }
        let m = DMatrix::from_fn(l, l, |i, j| r.matrix[i][j]);
        SsCovariance::new(r.order, r.inputs, r.outputs, m)
    }
}

impl From<SsCovariance> for SsCovarianceRepr {
    fn from(c: SsCovariance) -> Self {
        SsCovarianceRepr {
            order: c.order,
            inputs: c.inputs,
            outputs: c.outputs,
            matrix: c
                .matrix
                .row_iter()
                .map(|r| r.iter().copied().collect())
                .collect(),
        }
    }
}

/// L = n² + n n_u + n_y n + n_y n_u: the entries of (A, B, C, D).
pub fn parameter_count(order: usize, inputs: usize, outputs: usize) -> usize {
    order * order + order * inputs + outputs * order + outputs * inputs
}

impl SsCovariance {
    /// The covariance `matrix` (L × L, module docs) of a model with these
    /// dimensions.
    ///
    /// Errors: [`Error::DimensionMismatch`] for another size,
    /// [`Error::InvalidArgument`] when not finite or not symmetric (within
    /// 1e-8 of its largest entry) or with a negative diagonal entry.
    pub fn new(order: usize, inputs: usize, outputs: usize, matrix: DMatrix<f64>) -> Result<Self> {
        let l = parameter_count(order, inputs, outputs);
        if matrix.shape() != (l, l) {
            return Err(Error::DimensionMismatch {
                what: "state-space covariance",
                expected: format!("{l}x{l}"),
                got: format!("{}x{}", matrix.nrows(), matrix.ncols()),
            });
        }
        let bad = |reason: String| Error::InvalidArgument {
            what: "state-space covariance",
            reason,
        };
        if matrix.iter().any(|v| !v.is_finite()) {
            return Err(bad("has a non-finite entry".into()));
        }
        let scale = matrix.amax().max(f64::MIN_POSITIVE);
        if (&matrix - matrix.transpose()).amax() > 1e-8 * scale {
            return Err(bad("is not symmetric".into()));
        }
        if matrix.diagonal().iter().any(|v| *v < 0.0) {
            return Err(bad("has a negative variance".into()));
        }
        Ok(SsCovariance {
            order,
            inputs,
            outputs,
            matrix,
        })
    }

    /// P (L × L).
    pub fn matrix(&self) -> &DMatrix<f64> {
        &self.matrix
    }

    /// θ of `model` ([vec A; vec B; vec C; vec D]).
    ///
    /// Errors: [`Error::DimensionMismatch`] when `model` is not of this
    /// covariance's dimensions.
    pub fn parameters(&self, model: &StateSpace) -> Result<DVector<f64>> {
        self.check(model)?;
        Ok(DVector::from_iterator(
            self.matrix.nrows(),
            model
                .a()
                .iter()
                .chain(model.b().iter())
                .chain(model.c().iter())
                .chain(model.d().iter())
                .copied(),
        ))
    }

    /// The standard deviations of the entries of A, B, C and D (√ of P's
    /// diagonal, as the matrices): the "±" of each entry (MATLAB's
    /// `present`), which depend on the realisation's basis.
    pub fn entry_std(&self) -> [DMatrix<f64>; 4] {
        let (n, nu, ny) = (self.order, self.inputs, self.outputs);
        let sd: Vec<f64> = self.matrix.diagonal().iter().map(|v| v.sqrt()).collect();
        let mut at = 0;
        let mut take = |r: usize, c: usize| {
            let m = DMatrix::from_column_slice(r, c, &sd[at..at + r * c]);
            at += r * c;
            m
        };
        [take(n, n), take(n, nu), take(ny, n), take(ny, nu)]
    }

    /// The entries of (A, B, C, D) with their standard deviations, one
    /// matrix per block of lines: "A =" then rows of "v (±σ)" (MATLAB's
    /// `present` for an idss model). The deviations are those of this
    /// realisation's entries (another basis has others; the responses'
    /// deviations do not depend on it).
    ///
    /// Errors: [`Error::DimensionMismatch`] for a model of other
    /// dimensions.
    pub fn present(&self, model: &StateSpace) -> Result<String> {
        self.check(model)?;
        let sd = self.entry_std();
        let mats = [model.a(), model.b(), model.c(), model.d()];
        let mut out = String::new();
        for ((name, m), s) in ["A", "B", "C", "D"].iter().zip(mats).zip(&sd) {
            if m.is_empty() {
                continue;
            }
            out += &format!("{name} =\n");
            for i in 0..m.nrows() {
                let cells: Vec<String> = (0..m.ncols())
                    .map(|j| format!("{:>11.4e} (±{:.2e})", m[(i, j)], s[(i, j)]))
                    .collect();
                out += &format!("  {}\n", cells.join("  "));
            }
        }
        Ok(out)
    }

    fn check(&self, model: &StateSpace) -> Result<()> {
        let got = (model.order(), model.n_inputs(), model.n_outputs());
        if got != (self.order, self.inputs, self.outputs) {
            return Err(Error::DimensionMismatch {
                what: "model for its covariance",
                expected: format!(
                    "{} states, {} inputs, {} outputs",
                    self.order, self.inputs, self.outputs
                ),
                got: format!("{} states, {} inputs, {} outputs", got.0, got.1, got.2),
            });
        }
        Ok(())
    }

    /// `model` with θ moved by `delta`.
    fn moved(
        &self,
        model: &StateSpace,
        theta: &DVector<f64>,
        k: usize,
        h: f64,
    ) -> Result<StateSpace> {
        let (n, nu, ny) = (self.order, self.inputs, self.outputs);
        let mut t = theta.clone();
        t[k] += h;
        let s = t.as_slice();
        let mut at = 0;
        let mut take = |r: usize, c: usize| {
            let m = DMatrix::from_column_slice(r, c, &s[at..at + r * c]);
            at += r * c;
            m
        };
        let (a, b, c, d) = (take(n, n), take(n, nu), take(ny, n), take(ny, nu));
        StateSpace::new(a, b, c, d, model.ts())
    }

    /// The parameters with a non-zero variance, their central-difference
    /// steps h = 1e-6 max(|θ_k|, σ_k) and the models at θ ± h e_k.
    fn perturbations(
        &self,
        model: &StateSpace,
    ) -> Result<Vec<(usize, f64, StateSpace, StateSpace)>> {
        let theta = self.parameters(model)?;
        (0..theta.len())
            .filter(|&k| self.matrix[(k, k)] > 0.0)
            .map(|k| {
                let sd = self.matrix[(k, k)].sqrt();
                let h = 1e-6 * theta[k].abs().max(sd);
                Ok((
                    k,
                    h,
                    self.moved(model, &theta, k, h)?,
                    self.moved(model, &theta, k, -h)?,
                ))
            })
            .collect()
    }

    /// √(gᵀ P g) over the parameters `idx` (the others have no variance).
    fn spread(&self, idx: &[usize], g: &[f64]) -> f64 {
        let mut s = 0.0;
        for (r, &kr) in idx.iter().enumerate() {
            for (c, &kc) in idx.iter().enumerate() {
                s += g[r] * self.matrix[(kr, kc)] * g[c];
            }
        }
        s.max(0.0).sqrt()
    }

    /// Standard deviations of |G| and arg G of `model` at the frequencies
    /// `w` (rad per time unit; [`StateSpace::freqresp`]'s), one n_y × n_u
    /// matrix per frequency (module docs).
    ///
    /// Errors: [`Error::DimensionMismatch`] for a model of other
    /// dimensions; those of [`StateSpace::freqresp`].
    pub fn freqresp_std(&self, model: &StateSpace, w: &[f64]) -> Result<FreqStd> {
        let g0 = model.freqresp(w)?;
        let (idx, grads) = self.freq_gradients(model, w)?;
        Ok(crate::polymodel::uncertainty::freq_std_of(
            &g0,
            &grads,
            (self.outputs, self.inputs),
            |v| self.spread(&idx, v),
        ))
    }

    /// The parameters with a variance and the frequency response's
    /// gradient along each (central differences), per frequency of `w`.
    fn freq_gradients(
        &self,
        model: &StateSpace,
        w: &[f64],
    ) -> Result<(Vec<usize>, Vec<Responses>)> {
        let pert = self.perturbations(model)?;
        let idx: Vec<usize> = pert.iter().map(|p| p.0).collect();
        let grads = pert
            .iter()
            .map(|(_, h, up, down)| {
                let (gu, gd) = (up.freqresp(w)?, down.freqresp(w)?);
                Ok(gu
                    .iter()
                    .zip(&gd)
                    .map(|(a, b)| (a - b) / Complex64::new(2.0 * h, 0.0))
                    .collect())
            })
            .collect::<Result<_>>()?;
        Ok((idx, grads))
    }

    /// The 2 × 2 covariance of (Re G_ij, Im G_ij) at each frequency of
    /// `w`: what a joint confidence region of the complex response needs
    /// (an ellipse: the points within the χ²₂ quantile of its Mahalanobis
    /// distance), one n_y × n_u matrix of them per frequency.
    ///
    /// Errors: as [`freqresp_std`](Self::freqresp_std).
    pub fn freqresp_cov(
        &self,
        model: &StateSpace,
        w: &[f64],
    ) -> Result<Vec<DMatrix<[[f64; 2]; 2]>>> {
        let (idx, grads) = self.freq_gradients(model, w)?;
        let (ny, nu) = (self.outputs, self.inputs);
        Ok((0..w.len())
            .map(|f| {
                DMatrix::from_fn(ny, nu, |i, j| {
                    let re: Vec<f64> = grads.iter().map(|gk| gk[f][(i, j)].re).collect();
                    let im: Vec<f64> = grads.iter().map(|gk| gk[f][(i, j)].im).collect();
                    let q = |x: &[f64], y: &[f64]| {
                        let mut s = 0.0;
                        for (r, &kr) in idx.iter().enumerate() {
                            for (c, &kc) in idx.iter().enumerate() {
                                s += x[r] * self.matrix[(kr, kc)] * y[c];
                            }
                        }
                        s
                    };
                    let (rr, ri, ii) = (q(&re, &re), q(&re, &im), q(&im, &im));
                    [[rr, ri], [ri, ii]]
                })
            })
            .collect())
    }

    /// Standard deviations of the step responses' samples of `model` (one
    /// `samples × n_y` matrix per input, as [`StateSpace::step`] gives the
    /// responses), by first-order propagation (module docs).
    ///
    /// Errors: as [`freqresp_std`](Self::freqresp_std) and
    /// [`StateSpace::step`].
    pub fn step_std(&self, model: &StateSpace, samples: usize) -> Result<Vec<DMatrix<f64>>> {
        let pert = self.perturbations(model)?;
        let idx: Vec<usize> = pert.iter().map(|p| p.0).collect();
        let grads: Vec<Vec<DMatrix<f64>>> = pert
            .iter()
            .map(|(_, h, up, down)| {
                let (su, sd) = (up.step(samples, None)?, down.step(samples, None)?);
                Ok(su
                    .iter()
                    .zip(&sd)
                    .map(|(a, b)| (a - b) / (2.0 * h))
                    .collect())
            })
            .collect::<Result<_>>()?;
        let (ny, nu) = (self.outputs, self.inputs);
        Ok((0..nu)
            .map(|j| {
                DMatrix::from_fn(samples, ny, |t, i| {
                    let g: Vec<f64> = grads.iter().map(|gk| gk[j][(t, i)]).collect();
                    self.spread(&idx, &g)
                })
            })
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn first_order() -> StateSpace {
        StateSpace::new(
            DMatrix::from_element(1, 1, 0.8),
            DMatrix::from_element(1, 1, 0.5),
            DMatrix::from_element(1, 1, 1.0),
            DMatrix::zeros(1, 1),
            Some(1.0),
        )
        .unwrap()
    }

    /// G(e^{jω}) = c b / (e^{jω} − a): with only b uncertain (σ_b), |G|
    /// has σ = |G| σ_b / b and the phase none; with only a uncertain,
    /// σ_arg = |∂ arg G/∂a| σ_a = σ_a |Im(1/(e^{jω} − a))|.
    #[test]
    fn first_order_spreads_are_the_analytic_ones() {
        let g = first_order();
        let w = [0.1, 1.0, 2.5];
        let mut p = DMatrix::zeros(4, 4);
        p[(1, 1)] = 1e-4; // σ_b = 0.01
        let cov = SsCovariance::new(1, 1, 1, p).unwrap();
        let s = cov.freqresp_std(&g, &w).unwrap();
        let resp = g.freqresp(&w).unwrap();
        for (k, r) in resp.iter().enumerate() {
            let want = r[(0, 0)].norm() * 0.01 / 0.5;
            assert!((s.magnitude[k][(0, 0)] - want).abs() < 1e-8 * want);
            assert!(s.phase[k][(0, 0)] < 1e-9);
        }
        let mut p = DMatrix::zeros(4, 4);
        p[(0, 0)] = 4e-4; // σ_a = 0.02
        let cov = SsCovariance::new(1, 1, 1, p).unwrap();
        let s = cov.freqresp_std(&g, &w).unwrap();
        for (k, wk) in w.iter().enumerate() {
            let z = Complex64::from_polar(1.0, *wk) - 0.8;
            let want = 0.02 * (1.0 / z).im.abs();
            assert!((s.phase[k][(0, 0)] - want).abs() < 1e-6 * want.max(1e-12));
        }
        // The step: y(t) = b (1 − aᵗ)/(1 − a) (t ≥ 1), σ from b alone.
        let mut p = DMatrix::zeros(4, 4);
        p[(1, 1)] = 1e-4;
        let cov = SsCovariance::new(1, 1, 1, p).unwrap();
        let st = cov.step_std(&g, 20).unwrap();
        let y = g.step(20, None).unwrap();
        for t in 0..20 {
            let want = y[0][(t, 0)].abs() * 0.01 / 0.5;
            assert!(
                (st[0][(t, 0)] - want).abs() < 1e-8 * want.max(1e-12),
                "t {t}"
            );
        }
        // The (Re, Im) covariance agrees with the magnitude's σ when only
        // b (a pure scaling of G) is uncertain: Var|G| = Var along G.
        let c = cov.freqresp_cov(&g, &w).unwrap();
        for (k, r) in resp.iter().enumerate() {
            let m = c[k][(0, 0)];
            let z = r[(0, 0)];
            let along =
                (z.re * z.re * m[0][0] + 2.0 * z.re * z.im * m[0][1] + z.im * z.im * m[1][1])
                    / z.norm_sqr();
            let want = (z.norm() * 0.01 / 0.5).powi(2);
            assert!((along - want).abs() < 1e-7 * want);
        }
    }

    #[test]
    fn bad_covariances_are_refused_and_json_round_trips() {
        assert!(SsCovariance::new(1, 1, 1, DMatrix::zeros(3, 3)).is_err());
        let mut p = DMatrix::zeros(4, 4);
        p[(0, 1)] = 1.0;
        assert!(SsCovariance::new(1, 1, 1, p).is_err());
        let mut p = DMatrix::zeros(4, 4);
        p[(2, 2)] = -1.0;
        assert!(SsCovariance::new(1, 1, 1, p).is_err());
        let p = DMatrix::from_fn(
            4,
            4,
            |i, j| if i == j { 1e-3 * (i + 1) as f64 } else { 1e-5 },
        );
        let cov = SsCovariance::new(1, 1, 1, p).unwrap();
        let json = serde_json::to_string(&cov).unwrap();
        let back: SsCovariance = serde_json::from_str(&json).unwrap();
        assert_eq!(back, cov);
        assert!(
            serde_json::from_str::<SsCovariance>(
                r#"{"order":1,"inputs":1,"outputs":1,"matrix":[[1]]}"#
            )
            .is_err()
        );
        let [sa, sb, _, _] = cov.entry_std();
        assert!((sa[(0, 0)] - 1e-3f64.sqrt()).abs() < 1e-15);
        assert!((sb[(0, 0)] - 2e-3f64.sqrt()).abs() < 1e-15);
        assert!(cov.parameters(&first_order()).unwrap().len() == 4);
    }
}

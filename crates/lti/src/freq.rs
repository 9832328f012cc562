//! Frequency response, Bode data, H2 and H∞ norms.

use nalgebra::DMatrix;
use num_complex::Complex64;

use crate::error::{Error, Result, check_scalar};
use crate::la;
use crate::ss::StateSpace;

/// Bode data of a p×m system at the frequencies `omega` (rad/s).
#[derive(Debug, Clone, PartialEq)]
pub struct Bode {
    /// Frequencies in rad/s (as given).
    pub omega: Vec<f64>,
    /// |G(jω)| per frequency (p×m each, absolute value, not dB).
    pub magnitude: Vec<DMatrix<f64>>,
    /// Phase in degrees per frequency, unwrapped along the frequency axis
    /// entry by entry (jumps > 180° removed by ±360°).
    pub phase_deg: Vec<DMatrix<f64>>,
}

/// Options of [`StateSpace::hinf_norm`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HinfOptions {
    /// Relative tolerance: the returned norm γ satisfies
    /// γ ≤ ‖G‖∞ ≤ (1 + 2·rel_tol)γ. Default 1e-8.
    pub rel_tol: f64,
    /// Maximum number of Hamiltonian iterations. Default 100.
    pub max_iter: usize,
}

impl Default for HinfOptions {
    fn default() -> Self {
        Self {
            rel_tol: 1e-8,
            max_iter: 100,
        }
    }
}

/// Result of [`StateSpace::hinf_norm`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HinfNorm {
    /// ‖G‖∞ (a lower bound within the relative tolerance).
    pub norm: f64,
    /// A frequency in rad/s where σ_max(G) attains `norm` (discrete: θ/T
    /// with θ ∈ [0, π]); `f64::INFINITY` for a continuous peak at ω → ∞.
    pub peak_frequency: f64,
    /// Hamiltonian iterations used.
    pub iterations: usize,
}

impl StateSpace {
    /// G at a complex point: C (sI − A)⁻¹ B + D (LU solve, O(n³)).
    ///
    /// Errors: [`Error::Infinite`] when `s` is a pole.
    pub fn eval_complex(&self, s: Complex64) -> Result<DMatrix<Complex64>> {
        check_scalar("s (real part)", s.re)?;
        check_scalar("s (imaginary part)", s.im)?;
        let n = self.order();
        let d = self.d().map(|x| Complex64::new(x, 0.0));
        if n == 0 {
            return Ok(d);
        }
        let m = DMatrix::from_fn(n, n, |i, j| {
            let v = Complex64::new(-self.a()[(i, j)], 0.0);
            if i == j { v + s } else { v }
        });
        let b = self.b().map(|x| Complex64::new(x, 0.0));
        let lu = m.lu();
        let x = lu.solve(&b).ok_or_else(|| Error::Infinite {
            what: "frequency response",
            reason: format!("{s} is a pole"),
        })?;
        if x.iter().any(|v| !v.re.is_finite() || !v.im.is_finite()) {
            return Err(Error::Infinite {
                what: "frequency response",
                reason: format!("{s} is a pole"),
            });
        }
        Ok(self.c().map(|x| Complex64::new(x, 0.0)) * x + d)
    }

    /// Frequency response at `omega` (rad/s): G(jω) for continuous models,
    /// G(e^{jωT}) for discrete ones. O(len·n³).
    pub fn freqresp(&self, omega: &[f64]) -> Result<Vec<DMatrix<Complex64>>> {
        omega
            .iter()
            .map(|&w| {
                check_scalar("omega", w)?;
                self.eval_complex(self.point(w))
            })
            .collect()
    }

    fn point(&self, w: f64) -> Complex64 {
        match self.ts() {
            None => Complex64::new(0.0, w),
            Some(t) => Complex64::from_polar(1.0, w * t),
        }
    }

    /// Bode magnitude and unwrapped phase at `omega` (rad/s).
    pub fn bode(&self, omega: &[f64]) -> Result<Bode> {
        let g = self.freqresp(omega)?;
        let (p, m) = (self.n_outputs(), self.n_inputs());
        let magnitude: Vec<DMatrix<f64>> = g.iter().map(|gk| gk.map(|z| z.norm())).collect();
        let mut phase_deg: Vec<DMatrix<f64>> = g
            .iter()
            .map(|gk| gk.map(|z| z.arg().to_degrees()))
            .collect();
        for i in 0..p {
            for j in 0..m {
                for k in 1..phase_deg.len() {
                    let prev = phase_deg[k - 1][(i, j)];
                    let raw = phase_deg[k][(i, j)];
                    phase_deg[k][(i, j)] = raw - 360.0 * ((raw - prev) / 360.0).round();
                }
            }
        }
        Ok(Bode {
            omega: omega.to_vec(),
            magnitude,
            phase_deg,
        })
    }

    /// H2 norm. Continuous: √trace(C P Cᵀ), A P + P Aᵀ + B Bᵀ = 0 (requires
    /// D = 0, otherwise [`Error::Infinite`]). Discrete:
    /// √trace(C P Cᵀ + D Dᵀ), A P Aᵀ − P + B Bᵀ = 0. Requires stability
    /// ([`Error::Unstable`]). O(n³).
    pub fn h2_norm(&self) -> Result<f64> {
        if !self.is_discrete() && self.d().iter().any(|&x| x != 0.0) {
            return Err(Error::Infinite {
                what: "H2 norm",
                reason: "continuous system with D != 0".into(),
            });
        }
        let p = self.controllability_gramian()?;
        let mut v = (self.c() * p * self.c().transpose()).trace();
        if self.is_discrete() {
            v += (self.d() * self.d().transpose()).trace();
        }
        Ok(v.max(0.0).sqrt())
    }

    /// H∞ norm and peak frequency of a stable model.
    ///
    /// Continuous: the Bruinsma–Steinbuch / Boyd–Balakrishnan iteration.
    /// Start from γ_lb = max σ_max over ω ∈ {0, ∞, |pᵢ|}; at
    /// γ = (1 + 2 rel_tol)γ_lb form the Hamiltonian
    /// H(γ) = [A − BR⁻¹DᵀC, −γBR⁻¹Bᵀ; γCᵀS⁻¹C, −Aᵀ + CᵀDR⁻¹Bᵀ],
    /// R = DᵀD − γ²I, S = DDᵀ − γ²I, whose imaginary eigenvalues jωᵢ are
    /// exactly the frequencies where γ is a singular value of G(jω). If there
    /// are none, ‖G‖∞ < γ and the iteration stops; otherwise γ_lb becomes the
    /// largest σ_max at the midpoints of consecutive ωᵢ (quadratic
    /// convergence). Each iteration costs one 2n×2n eigenvalue problem, O(n³).
    ///
    /// Discrete: the norm-preserving bilinear map z = (1 + s)/(1 − s),
    /// A_c = (A + I)⁻¹(A − I), B_c = √2(A + I)⁻¹B, C_c = √2 C(A + I)⁻¹,
    /// D_c = D − C(A + I)⁻¹B, θ = 2 atan ω. When a pole is closer to z = −1
    /// than to z = +1, the model is first rotated by z ↦ −z ((−A, −B, C, D),
    /// θ shifted by π) so the inverted matrix stays well conditioned.
    ///
    /// Errors: [`Error::Unstable`], invalid options, [`Error::NoConvergence`].
    pub fn hinf_norm(&self, opts: &HinfOptions) -> Result<HinfNorm> {
        check_scalar("rel_tol", opts.rel_tol)?;
        if opts.rel_tol <= 0.0 {
            return Err(Error::InvalidArgument {
                what: "rel_tol",
                reason: "must be positive".into(),
            });
        }
        self.require_stable("hinf_norm")?;
        match self.ts() {
            None => hinf_continuous(self.a(), self.b(), self.c(), self.d(), opts),
            Some(t) => {
                let n = self.order();
                let i = DMatrix::<f64>::identity(n, n);
                let poles = self.poles()?;
                let dist = |s: f64| {
                    poles
                        .iter()
                        .map(|p| (p * s + 1.0).norm())
                        .fold(f64::INFINITY, f64::min)
                };
                let sigma = if dist(1.0) >= dist(-1.0) { 1.0 } else { -1.0 };
                let a = self.a() * sigma;
                let b = self.b() * sigma;
                let api = la::inv(&(&a + &i))?;
                let ac = &api * (&a - &i);
                let bc = &api * &b * std::f64::consts::SQRT_2;
                let cc = self.c() * &api * std::f64::consts::SQRT_2;
                let dc = self.d() - self.c() * &api * &b;
                let r = hinf_continuous(&ac, &bc, &cc, &dc, opts)?;
                let phi = if r.peak_frequency.is_infinite() {
                    std::f64::consts::PI
                } else {
                    2.0 * r.peak_frequency.atan()
                };
                let mut theta = if sigma > 0.0 {
                    phi
                } else {
                    phi + std::f64::consts::PI
                };
                if theta > std::f64::consts::PI {
                    theta = 2.0 * std::f64::consts::PI - theta;
                }
                Ok(HinfNorm {
                    norm: r.norm,
                    peak_frequency: theta.abs() / t,
                    iterations: r.iterations,
                })
            }
        }
    }
}

fn sigma_max(g: &DMatrix<Complex64>) -> f64 {
    if g.is_empty() {
        return 0.0;
    }
    g.clone()
        .singular_values()
        .iter()
        .fold(0.0, |a: f64, &b| a.max(b))
}

fn hinf_continuous(
    a: &DMatrix<f64>,
    b: &DMatrix<f64>,
    c: &DMatrix<f64>,
    d: &DMatrix<f64>,
    opts: &HinfOptions,
) -> Result<HinfNorm> {
    let sys = StateSpace::from_parts(a.clone(), b.clone(), c.clone(), d.clone(), None);
    let n = a.nrows();
    let (p, m) = d.shape();
    let sd = la::svd(d)?.1.first().copied().unwrap_or(0.0);
    let mut gamma_lb = sd;
    let mut peak = f64::INFINITY;
    if n == 0 || p == 0 || m == 0 {
        return Ok(HinfNorm {
            norm: sd,
            peak_frequency: if sd > 0.0 { f64::INFINITY } else { 0.0 },
            iterations: 0,
        });
    }
    let mut cands = vec![0.0];
    for pl in la::eigenvalues(a)? {
        if pl.im >= 0.0 {
            cands.push(pl.norm());
        }
    }
    for w in cands {
        let s = sigma_max(&sys.eval_complex(Complex64::new(0.0, w))?);
        if s > gamma_lb {
            gamma_lb = s;
            peak = w;
        }
    }
    if gamma_lb == 0.0 {
        return Ok(HinfNorm {
            norm: 0.0,
            peak_frequency: 0.0,
            iterations: 0,
        });
    }
    for it in 1..=opts.max_iter {
        let gamma = (1.0 + 2.0 * opts.rel_tol) * gamma_lb;
        let g2 = gamma * gamma;
        let r = d.transpose() * d - DMatrix::<f64>::identity(m, m) * g2;
        let s = d * d.transpose() - DMatrix::<f64>::identity(p, p) * g2;
        let ri = la::inv(&r)?;
        let si = la::inv(&s)?;
        let mut h = DMatrix::<f64>::zeros(2 * n, 2 * n);
        h.view_mut((0, 0), (n, n))
            .copy_from(&(a - b * &ri * d.transpose() * c));
        h.view_mut((0, n), (n, n))
            .copy_from(&(b * &ri * b.transpose() * (-gamma)));
        h.view_mut((n, 0), (n, n))
            .copy_from(&(c.transpose() * &si * c * gamma));
        h.view_mut((n, n), (n, n))
            .copy_from(&(-a.transpose() + c.transpose() * d * &ri * b.transpose()));
        let hn = h.norm().max(1.0);
        let mut ws: Vec<f64> = la::eigenvalues(&h)?
            .into_iter()
            .filter(|l| l.re.abs() <= 1e-9 * hn && l.im >= 0.0)
            .map(|l| l.im)
            .collect();
        if ws.is_empty() {
            return Ok(HinfNorm {
                norm: gamma_lb,
                peak_frequency: peak,
                iterations: it,
            });
        }
        ws.sort_by(f64::total_cmp);
        // a single crossing: pair it with 0 (the symmetric −ω)
        if ws.len() == 1 {
            ws.insert(0, 0.0);
        }
        let mut best = gamma_lb;
        let mut best_w = peak;
        for k in 0..ws.len() - 1 {
            let wm = 0.5 * (ws[k] + ws[k + 1]);
            let sv = sigma_max(&sys.eval_complex(Complex64::new(0.0, wm))?);
            if sv > best {
                best = sv;
                best_w = wm;
            }
        }
        if best <= gamma {
            // no progress: the crossings were rounding artefacts at the peak
            return Ok(HinfNorm {
                norm: gamma_lb.max(best),
                peak_frequency: if best > gamma_lb { best_w } else { peak },
                iterations: it,
            });
        }
        gamma_lb = best;
        peak = best_w;
    }
    Err(Error::NoConvergence {
        what: "hinf_norm",
        iterations: opts.max_iter,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_order_response_and_norms() {
        // 1/(s + 2): |G(j2)| = 1/(2√2), ‖G‖∞ = 0.5 at ω = 0, ‖G‖₂ = 1/2
        let s = StateSpace::new(
            DMatrix::from_element(1, 1, -2.0),
            DMatrix::identity(1, 1),
            DMatrix::identity(1, 1),
            DMatrix::zeros(1, 1),
            None,
        )
        .unwrap();
        let g = s.freqresp(&[2.0]).unwrap();
        assert!((g[0][(0, 0)].norm() - 1.0 / (2.0 * 2f64.sqrt())).abs() < 1e-15);
        let h = s.hinf_norm(&HinfOptions::default()).unwrap();
        assert!((h.norm - 0.5).abs() < 1e-12 && h.peak_frequency == 0.0);
        assert!((s.h2_norm().unwrap() - 0.5).abs() < 1e-14);
        assert!(matches!(
            s.eval_complex(Complex64::new(-2.0, 0.0)),
            Err(Error::Infinite { .. })
        ));
    }
}

//! Accuracy of a recovered plant relative to the true one: the numbers behind
//! Ren & Zhu's findings (DC-gain error, low-frequency error below the PRBS
//! limit, right-half-plane poles).
//!
//! The PRBS of order n (m = 2ⁿ − 1) held n_r samples of T seconds has period
//! 2 m n_r T (inverse PRBS, eq. 7): its lowest excited frequency is
//! f₀ = 1/(2 m n_r T) Hz, ω₀ = 2π f₀ rad/s ([`prbs_low_frequency`]).
//! Below ω₀ the closed-loop model is not constrained by the data.

use lifted_lti::{SisoTf, StateSpace, TransferFunction};
use nalgebra::DMatrix;
use num_complex::Complex64;

use crate::error::{Error, Result, dims};

/// A model whose frequency response, DC gain and poles can be evaluated:
/// [`StateSpace`], [`TransferFunction`] and [`SisoTf`] (continuous).
pub trait FrequencyModel {
    /// G(jω) (continuous) or G(e^{jωT}) (discrete), ω in rad/s.
    fn response(&self, omega: f64) -> Result<DMatrix<Complex64>>;
    /// Poles (continuous: s-plane; discrete: z-plane).
    fn model_poles(&self) -> Result<Vec<Complex64>>;
    /// Zeros (SISO: numerator roots; MIMO: transmission zeros).
    fn model_zeros(&self) -> Result<Vec<Complex64>>;
    /// Sample period (`None`: continuous).
    fn period(&self) -> Option<f64>;
}

impl FrequencyModel for StateSpace {
    fn response(&self, omega: f64) -> Result<DMatrix<Complex64>> {
        let mut r = self.freqresp(&[omega])?;
        r.pop().ok_or_else(|| Error::InvalidArgument {
            what: "frequency response",
            reason: "empty".into(),
        })
    }
    fn model_poles(&self) -> Result<Vec<Complex64>> {
        Ok(self.poles()?)
    }
    fn model_zeros(&self) -> Result<Vec<Complex64>> {
        Ok(self.zeros()?)
    }
    fn period(&self) -> Option<f64> {
        self.ts()
    }
}

impl FrequencyModel for TransferFunction {
    fn response(&self, omega: f64) -> Result<DMatrix<Complex64>> {
        let x = match self.ts() {
            None => Complex64::new(0.0, omega),
            Some(t) => Complex64::from_polar(1.0, omega * t),
        };
        Ok(self.eval(x)?)
    }
    fn model_poles(&self) -> Result<Vec<Complex64>> {
        if self.is_siso() {
            Ok(self.poles()?)
        } else {
            Ok(self.to_ss()?.poles()?)
        }
    }
    fn model_zeros(&self) -> Result<Vec<Complex64>> {
        if self.is_siso() {
            Ok(self.zeros()?)
        } else {
            Ok(self.to_ss()?.zeros()?)
        }
    }
    fn period(&self) -> Option<f64> {
        self.ts()
    }
}

impl FrequencyModel for SisoTf {
    fn response(&self, omega: f64) -> Result<DMatrix<Complex64>> {
        let s = Complex64::new(0.0, omega);
        let d = self.den().eval_complex(s);
        if d.norm() == 0.0 {
            return Err(Error::InvalidArgument {
                what: "frequency response",
                reason: format!("s = {s} is a pole"),
            });
        }
        Ok(DMatrix::from_element(1, 1, self.num().eval_complex(s) / d))
    }
    fn model_poles(&self) -> Result<Vec<Complex64>> {
        Ok(self.den().roots()?)
    }
    fn model_zeros(&self) -> Result<Vec<Complex64>> {
        if self.num().is_zero() {
            Ok(vec![])
        } else {
            Ok(self.num().roots()?)
        }
    }
    fn period(&self) -> Option<f64> {
        None
    }
}

/// Lowest frequency excited by the inverse PRBS (rad/s):
/// ω₀ = 2π/(2 m n_r T), m = 2ⁿ − 1.
///
/// Errors: PRBS order out of range, `hold` = 0 or `ts` not positive.
pub fn prbs_low_frequency(prbs_order: u32, hold: usize, ts: f64) -> Result<f64> {
    let m = lifted_prbs::period(prbs_order)? as f64;
    if hold == 0 || !(ts.is_finite() && ts > 0.0) {
        return Err(Error::InvalidArgument {
            what: "hold / ts",
            reason: format!("need hold >= 1 and ts > 0, got {hold} and {ts}"),
        });
    }
    Ok(2.0 * std::f64::consts::PI / (2.0 * m * hold as f64 * ts))
}

fn spectral_norm(m: &DMatrix<Complex64>) -> f64 {
    if m.len() == 1 {
        return m[(0, 0)].norm();
    }
    m.clone()
        .singular_values()
        .iter()
        .copied()
        .fold(0.0, f64::max)
}

/// Relative frequency-response error ‖Ĝ(jω) − G(jω)‖₂/‖G(jω)‖₂ at each ω
/// (SISO: |Ĝ − G|/|G|, the measure of spec A2.5). O(len·n³).
///
/// Errors: size mismatch, a frequency on a pole.
pub fn relative_error_at<E: FrequencyModel + ?Sized, G: FrequencyModel + ?Sized>(
    estimate: &E,
    truth: &G,
    omega: &[f64],
) -> Result<Vec<f64>> {
    omega
        .iter()
        .map(|&w| {
            let e = estimate.response(w)?;
            let g = truth.response(w)?;
            if e.shape() != g.shape() {
                return Err(dims(
                    "estimate vs true plant",
                    format!("{:?}", g.shape()),
                    format!("{:?}", e.shape()),
                ));
            }
            Ok(spectral_norm(&(&e - &g)) / spectral_norm(&g))
        })
        .collect()
}

/// Relative DC-gain error ‖Ĝ(0) − G(0)‖₂/‖G(0)‖₂ (continuous: s = 0;
/// discrete: z = 1).
pub fn dc_gain_error<E: FrequencyModel + ?Sized, G: FrequencyModel + ?Sized>(
    estimate: &E,
    truth: &G,
) -> Result<f64> {
    Ok(relative_error_at(estimate, truth, &[0.0])?[0])
}

/// Accuracy summary of a recovered plant ([`accuracy`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Accuracy {
    /// Relative DC-gain error.
    pub dc_gain_error: f64,
    /// The frequency grid (rad/s).
    pub omega: Vec<f64>,
    /// Relative error at each grid frequency.
    pub errors: Vec<f64>,
    /// Largest relative error over the grid.
    pub max_error: f64,
    /// PRBS low-frequency limit ω₀ (rad/s), if given.
    pub prbs_limit: Option<f64>,
    /// Largest relative error at grid frequencies ≤ ω₀ (NaN if none or no limit).
    pub max_error_below_limit: f64,
    /// Poles of the estimate.
    pub poles: Vec<Complex64>,
    /// Poles of the true plant.
    pub true_poles: Vec<Complex64>,
    /// Zeros of the estimate.
    pub zeros: Vec<Complex64>,
    /// Zeros of the true plant.
    pub true_zeros: Vec<Complex64>,
    /// Unstable poles of the estimate (Re ≥ 0, or |z| ≥ 1 for discrete).
    pub unstable_poles: Vec<Complex64>,
    /// For each true pole, the distance to the nearest estimated pole.
    pub pole_distance: Vec<f64>,
}

fn is_unstable(p: Complex64, ts: Option<f64>) -> bool {
    match ts {
        None => p.re >= 0.0,
        Some(_) => p.norm() >= 1.0,
    }
}

/// DC-gain error, relative errors on `omega`, the maximum below the PRBS limit
/// `prbs_limit` (rad/s, from [`prbs_low_frequency`]) and a pole/zero
/// comparison, all relative to the true plant. O(len·n³).
///
/// Errors: an empty grid, size mismatch, a grid point on a pole.
pub fn accuracy<E: FrequencyModel + ?Sized, G: FrequencyModel + ?Sized>(
    estimate: &E,
    truth: &G,
    omega: &[f64],
    prbs_limit: Option<f64>,
) -> Result<Accuracy> {
    if omega.is_empty() {
        return Err(Error::InvalidArgument {
            what: "omega",
            reason: "the frequency grid is empty".into(),
        });
    }
    let errors = relative_error_at(estimate, truth, omega)?;
    let max_error = errors.iter().copied().fold(0.0, f64::max);
    let max_error_below_limit = match prbs_limit {
        Some(l) => omega
            .iter()
            .zip(&errors)
            .filter(|(w, _)| **w <= l)
            .map(|(_, e)| *e)
            .fold(f64::NAN, f64::max),
        None => f64::NAN,
    };
    let poles = estimate.model_poles()?;
    let true_poles = truth.model_poles()?;
    let pole_distance = true_poles
        .iter()
        .map(|t| {
            poles
                .iter()
                .map(|p| (p - t).norm())
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    let unstable_poles = poles
        .iter()
        .copied()
        .filter(|&p| is_unstable(p, estimate.period()))
        .collect();
    Ok(Accuracy {
        dc_gain_error: dc_gain_error(estimate, truth)?,
        omega: omega.to_vec(),
        errors,
        max_error,
        prbs_limit,
        max_error_below_limit,
        zeros: estimate.model_zeros()?,
        true_zeros: truth.model_zeros()?,
        poles,
        true_poles,
        unstable_poles,
        pole_distance,
    })
}

/// `n` logarithmically spaced frequencies from `lo` to `hi` (rad/s).
///
/// Errors: `n < 2`, or bounds not positive and increasing.
pub fn log_grid(lo: f64, hi: f64, n: usize) -> Result<Vec<f64>> {
    if n < 2 || !(lo > 0.0 && hi > lo && hi.is_finite()) {
        return Err(Error::InvalidArgument {
            what: "log_grid",
            reason: format!("need 0 < lo < hi and n >= 2, got {lo}, {hi}, {n}"),
        });
    }
    let (a, b) = (lo.ln(), hi.ln());
    Ok((0..n)
        .map(|i| (a + (b - a) * i as f64 / (n - 1) as f64).exp())
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prbs_limit_of_order_9() {
        // m = 511, T = 5 ms: period 5.11 s, ω₀ = 2π/5.11 ≈ 1.2296 rad/s
        let w = prbs_low_frequency(9, 1, 0.005).unwrap();
        assert!((w - 2.0 * std::f64::consts::PI / 5.11).abs() < 1e-12);
    }

    #[test]
    fn errors_of_a_scaled_plant() {
        let g = SisoTf::from_coeffs(&[1.0], &[0.3, 1.0]).unwrap();
        let e = SisoTf::from_coeffs(&[1.1], &[0.3, 1.0]).unwrap();
        let acc = accuracy(&e, &g, &[0.01, 1.0], Some(0.1)).unwrap();
        assert!((acc.dc_gain_error - 0.1).abs() < 1e-12);
        assert!((acc.max_error_below_limit - 0.1).abs() < 1e-12);
        assert!(acc.unstable_poles.is_empty());
        assert!(acc.pole_distance[0] < 1e-12);
    }
}

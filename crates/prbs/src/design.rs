//! PRBS experiment design, Zhu 2000 §III.D step 1 and Table II.
//!
//! * `T_p = n_r T` with the smallest `n_r` such that `T_p ≥ margin / f_act`
//!   (the actuator executes every generated value; Table II: `T_p` three fuel-injection
//!   periods at 30 Hz, i.e. 0.1 s, `n_r = 10` at `T = 0.01 s`).
//! * The inverse PRBS has period `2 m T_p` and only odd harmonics of
//!   `f₀ = 1/(2 m T_p)` (because `u(k+m) = −u(k)`): the smallest `n` with
//!   `f₀ ≤ f_slow` is chosen (Table II: `n = 8`, period 51 s, `f₀ = 0.0196 Hz`,
//!   erratum Z-13).
//! * The spectrum is flat (eq. II-6) up to `1/(2T_p)`; the `n_r`-sample hold
//!   multiplies it by `|sinc(f T_p)|`, i.e. −3.9 dB at `1/(2T_p)` and a null at `1/T_p`.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result, check_amplitude, check_positive};
use crate::inverse::InversePrbsOptions;
use crate::mseq::{MAX_ORDER, MIN_ORDER, check_order};

/// Relative tolerance on ratios of user times (`0.1/0.01` is not exactly 10).
const RATIO_TOL: f64 = 1e-9;

/// What the experiment must achieve. Validated by [`design`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct DesignRequest {
    /// Output sample period `T` in seconds (Table II: 0.01). Default 0.01.
    pub output_period: f64,
    /// Fastest rate (Hz) at which the actuator can execute a new command
    /// (Table II: 30 Hz fuel injection at 600 rpm). Default 30.
    pub actuator_rate_hz: f64,
    /// Actuator margin: `T_p ≥ margin / actuator_rate_hz` (Table II: 3). Default 3.
    pub actuator_margin: f64,
    /// Slowest mode to excite, Hz (Table II: 0.025). Default 0.025.
    pub slowest_mode_hz: f64,
    /// PRBS magnitude `a` allowed by the process (Table II: 2 mm³/stroke). Default 1.
    pub amplitude: f64,
    /// Smallest order to propose (`q ≪ m` may demand more than the frequency rule).
    /// Default 2.
    pub min_order: u32,
}

impl Default for DesignRequest {
    fn default() -> Self {
        Self {
            output_period: 0.01,
            actuator_rate_hz: 30.0,
            actuator_margin: 3.0,
            slowest_mode_hz: 0.025,
            amplitude: 1.0,
            min_order: MIN_ORDER,
        }
    }
}

/// A proposed design, with the derived quantities and the reasoning.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DesignProposal {
    /// PRBS order `n`.
    pub order: u32,
    /// m-sequence period `m = 2ⁿ − 1`.
    pub m: u64,
    /// Hold factor `n_r = T_p / T` (eq. II-7).
    pub hold: usize,
    /// Magnitude `a`.
    pub amplitude: f64,
    /// Output sample period `T` (s).
    pub output_period: f64,
    /// PRBS generation period `T_p = n_r T` (s).
    pub generation_period: f64,
    /// Samples per period at the output rate, `2 n_r m`.
    pub period_samples: u64,
    /// One period (the record length), `2 m n_r T` seconds.
    pub record_length_s: f64,
    /// Lowest excited frequency `1/(2 m T_p)` Hz (erratum Z-13).
    pub fundamental_hz: f64,
    /// Upper end of the flat band, `1/(2 T_p)` Hz (hold attenuation −3.9 dB there).
    pub band_high_hz: f64,
    /// First spectral null of the hold, `1/T_p` Hz.
    pub hold_null_hz: f64,
    /// Human-readable reasoning, one step per line.
    pub explanation: String,
}

impl DesignProposal {
    /// Options of the proposed inverse PRBS.
    pub fn prbs_options(&self) -> InversePrbsOptions {
        InversePrbsOptions {
            order: self.order,
            amplitude: self.amplitude,
            hold: self.hold,
            taps: None,
        }
    }
}

/// Proposes `(n, n_r, a)` for a request. O(1).
///
/// # Errors
/// [`Error::InvalidParameter`] (non-finite or non-positive time, rate, margin or
/// frequency), [`Error::InvalidAmplitude`], [`Error::OrderOutOfRange`] (`min_order`),
/// [`Error::DesignInfeasible`] (the slowest mode needs an order above 32).
pub fn design(request: &DesignRequest) -> Result<DesignProposal> {
    let t = request.output_period;
    check_positive("output_period", t)?;
    check_positive("actuator_rate_hz", request.actuator_rate_hz)?;
    check_positive("actuator_margin", request.actuator_margin)?;
    check_positive("slowest_mode_hz", request.slowest_mode_hz)?;
    check_amplitude(request.amplitude)?;
    check_order(request.min_order)?;

    let min_tp = request.actuator_margin / request.actuator_rate_hz;
    let ratio = min_tp / t;
    let hold = ((ratio * (1.0 - RATIO_TOL)).ceil() as usize).max(1);
    let tp = hold as f64 * t;

    let min_m = 1.0 / (2.0 * request.slowest_mode_hz * tp);
    let order = (request.min_order..=MAX_ORDER)
        .find(|&n| ((1u64 << n) - 1) as f64 >= min_m * (1.0 - RATIO_TOL))
        .ok_or(Error::DesignInfeasible {
            slowest_mode_hz: request.slowest_mode_hz,
            generation_period: tp,
            max_order: MAX_ORDER,
        })?;
    let m = (1u64 << order) - 1;
    let period_samples = 2 * hold as u64 * m;
    let record_length_s = period_samples as f64 * t;
    let fundamental_hz = 1.0 / (2.0 * m as f64 * tp);
    let band_high_hz = 1.0 / (2.0 * tp);
    let explanation = format!(
        "1. The actuator executes at most {rate} Hz; with margin {margin} the PRBS \
         generation period must be T_p >= {margin}/{rate} = {min_tp:.6} s.\n\
         2. With output period T = {t} s, the smallest integer hold is n_r = ceil({ratio:.6}) = {hold}, \
         so T_p = n_r T = {tp:.6} s (eq. II-7).\n\
         3. The inverse PRBS repeats every 2 m T_p and holds only odd harmonics of \
         f0 = 1/(2 m T_p); exciting {fslow} Hz needs m >= {min_m:.3}, so n = {order} (m = {m}), \
         f0 = {fundamental_hz:.6} Hz (Zhu 2000 Table II, erratum Z-13).\n\
         4. One period is 2 m n_r = {period_samples} output samples = {record_length_s:.6} s; \
         record it after the response has become periodic (y(k) = -y(k + n_r m)).\n\
         5. The spectrum is flat (eq. II-6) up to 1/(2 T_p) = {band_high_hz:.6} Hz; the hold \
         attenuates it by |sinc(f T_p)| (-3.9 dB there, null at {null:.6} Hz).\n\
         6. Magnitude a = {a} as requested (chosen for the output signal-to-noise ratio).",
        rate = request.actuator_rate_hz,
        margin = request.actuator_margin,
        fslow = request.slowest_mode_hz,
        null = 1.0 / tp,
        a = request.amplitude,
    );
    Ok(DesignProposal {
        order,
        m,
        hold,
        amplitude: request.amplitude,
        output_period: t,
        generation_period: tp,
        period_samples,
        record_length_s,
        fundamental_hz,
        band_high_hz,
        hold_null_hz: 1.0 / tp,
        explanation,
    })
}

#[cfg(test)]
mod unit {
    use super::*;

    #[test]
    fn hold_rounds_up_to_respect_the_actuator() {
        // T_p >= 3/40 = 0.075 s with T = 0.01 s: n_r = 8 (7 would be too fast).
        let p = design(&DesignRequest {
            actuator_rate_hz: 40.0,
            ..Default::default()
        })
        .unwrap();
        assert_eq!(p.hold, 8);
        assert!(p.generation_period >= 0.075);
    }
}

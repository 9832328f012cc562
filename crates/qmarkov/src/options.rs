//! Options of the q-Markov Cover identification, with their defaults and sources.

use lifted_prbs::CorrelationMethod;
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// How the Markov parameters `H_τ` are estimated from the input–output correlation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum MarkovEstimator {
    /// Causal hold-deconvolution (spec A1.4 step 2, erratum Z-8). Default.
    /// `g(τ) = (1/(2m a²)) Σ_{p<2m} y(p n_r + τ) u(p)` correlates at the generation
    /// instants, then `h(τ) = g(τ) − g(τ−1) + h(τ−n_r)` undoes the hold. Equals the
    /// printed III-23 for `n_r = 1`.
    #[default]
    HoldDeconvolution,
    /// As printed, eq. (III-23): `H_τ = R_yw(τ) W(0)⁻¹` with the held input `w`.
    /// Correct only for `n_r = 1`; for `n_r > 1` it smears the Markov parameters
    /// (negative control (a) of spec A1.5).
    PrintedIII23,
}

/// Structure of the input weighting `W_q` (eq. III-13).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum WeightingStructure {
    /// Full block-Toeplitz `W_q` with blocks `W(|i−j|)` (errata Z-6, Z-7). Default.
    #[default]
    Toeplitz,
    /// Block-diagonal `I_q ⊗ W(0)`: wrong for `n_r > 1` (negative control (b) of
    /// spec A1.5); kept for comparison only.
    BlockDiagonal,
}

/// What each record holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum RecordMode {
    /// The record is exactly one steady-state period `2 n_r m`. Default.
    #[default]
    OnePeriod,
    /// The record is longer: the last full period is cut out of it (its start need
    /// not be a generation instant; the hold phase is read from the input).
    LastPeriod,
}

/// Options of [`identify_records`](crate::identify_records) and of the
/// [`QMarkov`](crate::QMarkov) identifier. Validated when used.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct QMarkovOptions {
    /// Number `q` of Markov / covariance parameters matched (step 3, eq. III-24),
    /// `2 ≤ q < n_r m` (eq. III-8). Default 60 (Zhu 2000 §IV).
    pub q: usize,
    /// Model order `r` (step 4, eq. III-25); `None` takes the largest gap of the
    /// eigenvalues of `D_q` ([`Diagnostics::suggested_order`](crate::Diagnostics)).
    /// Default `None`.
    pub order: Option<usize>,
    /// Largest order considered by the automatic choice. Default 20.
    pub max_auto_order: usize,
    /// Output weighting `Q` (n_y × n_y, symmetric positive definite; step 3,
    /// eq. III-6). `None` (default) is the identity.
    pub output_weighting: Option<DMatrix<f64>>,
    /// Hold factor `n_r = T_p / T`: each PRBS value lasts `n_r` output samples
    /// (eq. II-7). Default 1 (single rate, Zhu, Skelton & Li 1995).
    pub hold: usize,
    /// Order `n` of the m-sequence, `m = 2ⁿ − 1` (eq. II-1). Default 8 (Table II).
    pub prbs_order: u32,
    /// PRBS magnitude `a_l` per input channel (eq. II-4, III-13). `None` (default)
    /// reads it from each recorded input (`|w(k)|`, which must be constant).
    pub amplitudes: Option<Vec<f64>>,
    /// Whether each record is one period or must be cut. Default
    /// [`RecordMode::OnePeriod`].
    pub record: RecordMode,
    /// Largest accepted antisymmetry residual `‖y(k) + y(k+n_r m)‖ / ‖y‖` of the
    /// used period (erratum Z-12). Output noise alone contributes ≈ 1/SNR (std ratio).
    /// Default 0.5.
    pub steady_state_tol: f64,
    /// Subtract the mean of each output over the period (the steady-state response
    /// to the zero-mean PRBS has zero mean, so this only removes operating-point
    /// offsets). Default true.
    pub remove_mean: bool,
    /// Markov-parameter estimator. Default [`MarkovEstimator::HoldDeconvolution`].
    pub markov: MarkovEstimator,
    /// Structure of `W_q`. Default [`WeightingStructure::Toeplitz`].
    pub weighting: WeightingStructure,
    /// Eigenvalues of `D_q` with `|λ| ≤ eigen_tol · λ₁` count as zero (rank of `D_q`,
    /// q-identifiability test of Lemma III-1). Default 1e-10.
    pub eigen_tol: f64,
    /// Relative singular-value threshold for the rank of `P` and the pseudo-inverse
    /// `P⁺` (eq. III-28). Default 1e-10.
    pub rank_tol: f64,
    /// Orthogonal `U` of eq. (III-29) used when `P` is rank deficient; `None`
    /// (default) is the identity of the right size.
    pub rotation: Option<DMatrix<f64>>,
    /// Fail with [`Error::UnstableCover`] when Â has a pole on or outside the unit
    /// circle (erratum Z-9). Default true. When false, the cover is returned and
    /// [`Diagnostics::stable`](crate::Diagnostics) is false.
    pub require_stable: bool,
    /// Offer a stable model instead of rejecting an unstable cover: Â is
    /// re-estimated by the zero-padded shift Â = P_q⁺[P̄; 0] (eigenvalues
    /// inside the unit circle; the q parameters are then matched in the
    /// least-squares sense only). Checked before `require_stable`. Default
    /// false.
    pub enforce_stability: bool,
    /// Algorithm for the circular correlations at the q lags used: `Auto`
    /// (default) sums them directly, O(N q), when `q ≤ 4 log₂N` (or below
    /// [`lifted_prbs::FFT_THRESHOLD`] samples) and takes the FFT of
    /// `lifted-prbs` otherwise; `Direct` and `Fft` force one route.
    pub correlation: CorrelationMethod,
}

impl Default for QMarkovOptions {
    fn default() -> Self {
        Self {
            q: 60,
            order: None,
            max_auto_order: 20,
            output_weighting: None,
            hold: 1,
            prbs_order: 8,
            amplitudes: None,
            record: RecordMode::OnePeriod,
            steady_state_tol: 0.5,
            remove_mean: true,
            markov: MarkovEstimator::HoldDeconvolution,
            weighting: WeightingStructure::Toeplitz,
            eigen_tol: 1e-10,
            rank_tol: 1e-10,
            rotation: None,
            require_stable: true,
            enforce_stability: false,
            correlation: CorrelationMethod::Auto,
        }
    }
}

impl QMarkovOptions {
    /// `m = 2ⁿ − 1`, validating the PRBS order.
    pub(crate) fn m(&self) -> Result<usize> {
        Ok(lifted_prbs::period(self.prbs_order)? as usize)
    }

    /// Checks the scalar options; returns `(m, N = 2 n_r m)`.
    pub(crate) fn validate(&self) -> Result<(usize, usize)> {
        if self.hold == 0 {
            return Err(Error::InvalidOption {
                what: "hold",
                reason: "n_r must be at least 1".into(),
            });
        }
        let m = self.m()?;
        let half = self
            .hold
            .checked_mul(m)
            .ok_or_else(|| Error::InvalidOption {
                what: "hold",
                reason: format!(
                    "n_r = {} times the PRBS period {m} overflows the sample count",
                    self.hold
                ),
            })?;
        if half > usize::MAX / 2 {
            return Err(Error::InvalidOption {
                what: "hold",
                reason: format!("a record of 2 n_r m = 2 × {half} samples cannot be indexed"),
            });
        }
        if self.q < 2 || self.q >= half {
            return Err(Error::LagsOutOfRange {
                q: self.q,
                max_exclusive: half,
            });
        }
        if self.order == Some(0) {
            return Err(Error::InvalidOption {
                what: "order",
                reason: "the model order r must be at least 1".into(),
            });
        }
        if self.max_auto_order == 0 {
            return Err(Error::InvalidOption {
                what: "max_auto_order",
                reason: "must be at least 1".into(),
            });
        }
        for (what, v) in [
            ("steady_state_tol", self.steady_state_tol),
            ("eigen_tol", self.eigen_tol),
            ("rank_tol", self.rank_tol),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::InvalidOption {
                    what,
                    reason: format!("must be finite and non-negative, got {v}"),
                });
            }
        }
        if let Some(a) = &self.amplitudes {
            for (channel, &value) in a.iter().enumerate() {
                if !(value.is_finite() && value > 0.0) {
                    return Err(Error::InvalidAmplitude { channel, value });
                }
            }
        }
        Ok((m, 2 * half))
    }
}
